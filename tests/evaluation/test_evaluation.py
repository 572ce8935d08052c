"""Evaluation against held-out partners: the statistics against values worked by hand,
suites from files (their faults located, training partners kept apart), the runner's
normalisation, and ``flatland-ma evaluate`` for random play, a scripted policy and a
saved PPO checkpoint."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("scipy")

from flatland_ma.cli import main  # noqa: E402
from flatland_ma.evaluation import (  # noqa: E402
    elo,
    iqm,
    list_suites,
    load_suite,
    normalise,
    run_suite,
    stratified_bootstrap,
)
from flatland_ma.evaluation.runner import focal_agents  # noqa: E402
from flatland_ma.scenario.errors import ScenarioError  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

TINY = """\
description: "two short tasks"
training: [greedy]
tasks:
  - scenario: plate_relay
    focal: [runner]
    background: [planner, idle, random]
    scripted: [planner]
    episodes: 1
  - scenario: fruits_poisons_multi
    focal: [agent_0]
    background: [planner, idle, random]
    scripted: [planner]
    episodes: 1
    overrides: {episode: {max_steps: 60}}
"""


def _tiny(tmp_path, text=TINY) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(text)
    return path


def test_iqm_is_the_mean_of_the_middle_half():
    assert iqm([1, 2, 3, 4, 5, 6, 7, 8]) == 4.5  # (3 + 4 + 5 + 6) / 4
    assert iqm(range(10)) == 4.5  # two cut from each end: (2 + ... + 7) / 6
    assert iqm([0, 0, 0, 100]) == 0.0  # an outlier does not move it
    assert iqm([3.0]) == 3.0
    with pytest.raises(ValueError):
        iqm([])


def test_normalise_puts_random_at_0_and_the_best_scripted_at_1():
    np.testing.assert_allclose(normalise([2, 4, 6, 8], random=2, best=6), [0, 0.5, 1, 1.5])
    with pytest.raises(ValueError, match="above random"):
        normalise([1], random=3, best=3)


def test_the_bootstrap_resamples_within_each_task():
    # Two tasks, one all 0 and one all 1: every stratified resample keeps three of each,
    # so the interval is the point; pooled resampling would spread it.
    point, low, high = stratified_bootstrap([[0, 0, 0], [1, 1, 1]], statistic=np.mean)
    assert point == low == high == 0.5
    rng = np.random.default_rng(0)
    few = [rng.normal(size=5) for _ in range(3)]
    many = [rng.normal(size=200) for _ in range(3)]
    p1, l1, h1 = stratified_bootstrap(few, seed=1)
    p2, l2, h2 = stratified_bootstrap(many, seed=1)
    assert l1 <= p1 <= h1 and l2 <= p2 <= h2
    assert h2 - l2 < (h1 - l1) / 2  # more runs, a narrower interval
    assert stratified_bootstrap(few, seed=1) == (p1, l1, h1)  # seeded


def test_elo_fits_the_odds_of_the_results():
    ratings = elo([[0, 0.75], [0.25, 0]])
    assert ratings[0] - ratings[1] == pytest.approx(400 * math.log10(3), abs=1e-6)
    assert ratings.mean() == pytest.approx(1000)
    assert np.allclose(elo([[0, 0.5], [0.5, 0]]), 1000)
    ordered = elo([[0, 0.7, 0.9], [0.3, 0, 0.7], [0.1, 0.3, 0]])
    assert ordered[0] > ordered[1] > ordered[2]
    never = elo([[0, 1.0], [0.0, 0]])  # kept finite
    assert np.isfinite(never).all() and never[0] > never[1]
    with pytest.raises(ValueError):
        elo([[0, 2], [0, 0]])


def test_the_shipped_suite_holds_out_three_partners_per_role():
    assert "society" in list_suites()
    suite = load_suite("society")
    scenarios = {t.scenario for t in suite.tasks}
    assert {"fruits_poisons_multi", "coop_carry", "tug_of_war"} <= scenarios
    assert {"plate_relay", "signal_rooms"} <= scenarios
    import flatland_ma

    for task in suite.tasks:
        assert len(task.background) >= 3 and not set(task.background) & set(suite.training)
        env = flatland_ma.parallel_env(task.scenario, **task.overrides)
        assert focal_agents(env, task.focal)


def test_a_background_reserved_for_training_is_refused_where_it_is_written(tmp_path):
    first = TINY.index("[planner, idle, random]")  # the first task's background
    text = TINY[:first] + "[planner, greedy, random]" + TINY[first + 23 :]
    path = _tiny(tmp_path, text)
    with pytest.raises(ScenarioError, match=r"tiny.yaml:6: tasks\[0\]\.background\[1\].*reserved"):
        load_suite(path)
    path.write_text(TINY.replace("episodes: 1", "episodes: many", 1))
    with pytest.raises(ScenarioError, match=r"tiny.yaml:8: tasks\[0\]\.episodes"):
        load_suite(path)
    with pytest.raises(ValueError, match="no suite 'nope'"):
        load_suite("nope")


def test_the_best_scripted_policy_scores_1_and_random_play_0(tmp_path):
    """The policy under test meets the same partners with the same seeds as the
    baselines: played by the scripted policy itself it scores exactly 1 on average, and
    by random play exactly 0."""
    suite = load_suite(_tiny(tmp_path))
    scripted = run_suite(suite, "planner")
    for task in scripted["tasks"]:
        assert task["best_scripted"] == "planner" and task["mean"] == pytest.approx(1.0)
        assert len(task["normalised"]) == 3  # one episode per background policy
    random = run_suite(suite, "random")
    for task in random["tasks"]:
        assert task["mean"] == pytest.approx(0.0)
    low, high = scripted["aggregate"]["ci"]
    assert low <= scripted["aggregate"]["iqm"] <= high


def test_a_focal_name_must_be_an_agent_or_a_team(tmp_path):
    path = _tiny(tmp_path, TINY.replace("focal: [runner]", "focal: [pilot]"))
    with pytest.raises(ScenarioError, match=r"tiny.yaml:5: tasks\[0\]\.focal\[0\]: 'pilot' is no"):
        load_suite(path)


def test_the_command_scores_a_ppo_checkpoint_and_refuses_one_trained_with_the_partners(
    tmp_path, capsys
):
    pytest.importorskip("torch")
    csv = tmp_path / "seed_0.csv"
    command = [sys.executable, "-m", "baselines.ppo", "--scenario", "fruits_poisons_multi"]
    command += ["--num-envs", "1", "--num-steps", "64", "--total-timesteps", "256"]
    command += ["--checkpoint-every", "0", "--no-tensorboard", "--csv", str(csv)]
    subprocess.run(command, cwd=ROOT, check=True, capture_output=True, timeout=300)
    checkpoint = tmp_path / "seed_0.safetensors"
    only_foraging = TINY[TINY.index("  - scenario: fruits_poisons_multi") :]
    carry = (
        "  - scenario: coop_carry\n    focal: [agent_0]\n    background: [carrier, idle, random]\n"
        "    scripted: [carrier]\n    episodes: 1\n"
    )
    suite = _tiny(tmp_path, 'description: "foraging"\ntasks:\n' + only_foraging + carry)
    out = tmp_path / "report"
    assert main(["evaluate", str(checkpoint), "--suite", str(suite), "--out", str(out)]) == 0
    result = json.loads((out / "evaluation.json").read_text())
    assert result["policy"] == str(checkpoint) and len(result["tasks"]) == 2
    # Its network acts in Discrete(3): the carriers' Discrete(8) task is skipped, not scored.
    assert "Discrete(8)" in result["tasks"][1]["skipped"] and "normalised" in result["tasks"][0]
    assert (out / "evaluation.png").stat().st_size > 1000
    assert "all tasks (normalised)" in capsys.readouterr().out

    from tests.checkpoint_helpers import rewrite_description

    rewrite_description(
        checkpoint, lambda description: {**description, "trained_with": ["planner"]}
    )
    assert main(["evaluate", str(checkpoint), "--suite", str(suite), "--out", str(out)]) == 2
    assert "trained beside ['planner']" in capsys.readouterr().err


def test_crossplay_gives_a_matrix_and_elo(capsys, tmp_path):
    assert (
        main(
            [
                "evaluate",
                "--crossplay",
                "carrier",
                "idle",
                "--episodes",
                "1",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    result = json.loads((tmp_path / "crossplay.json").read_text())
    wins = np.array(result["wins"], dtype=float)
    assert wins.shape == (2, 2) and result["policies"] == ["carrier", "idle"]
    assert np.isnan(np.diag(wins)).all()  # a policy is not played against itself
    assert wins[0, 1] == 1.0 and wins[1, 0] == 0.0  # carriers beat a team that keeps still
    assert result["elo"][0] > result["elo"][1]
    assert "Elo" in capsys.readouterr().out
    assert (tmp_path / "crossplay.png").stat().st_size > 1000


@pytest.mark.parametrize(
    "name, scenario",
    [
        ("greedy", "fruits_poisons_multi"),
        ("planner", "plate_relay"),
        ("carrier", "coop_carry"),
        ("sniffer", "scent_rooms"),
        ("signaller", "signal_rooms"),
        ("follower", "signal_rooms"),
        ("random", "signal_rooms"),
        ("idle", "signal_rooms"),
    ],
)
def test_every_shipped_policy_is_a_policy_that_acts_in_its_agents_space(name, scenario):
    import flatland_ma
    from flatland_ma.policies import SHIPPED, Policy, make_policy

    assert name in SHIPPED
    env = flatland_ma.parallel_env(scenario)
    observations, _ = env.reset(seed=0)
    agent = env.possible_agents[-1]
    policy = make_policy(name, env, agent, seed=0)
    assert isinstance(policy, Policy)
    assert env.action_space(agent).contains(np.asarray(policy.act(observations[agent])))
