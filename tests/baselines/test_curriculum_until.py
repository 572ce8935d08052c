"""A curriculum's stages that end early on what the learner does (``until``): the gate
read from the stage's latest returns, the steps it leaves going to the stages after it,
the run's budget kept, the run's JSON saying which stage ended early, resumed runs going
on in the stage under way, and the key refused where it means nothing (a lifelong stream,
the last stage)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from baselines.curriculum import Stage, curriculum_stages, stage_ends, stages_record
from flatland_ma.lifelong.streams import load_stream
from flatland_ma.scenario.errors import ScenarioError

torch = pytest.importorskip("torch")

from baselines import ppo  # noqa: E402
from baselines.ppo_resume import periodic_checkpoints  # noqa: E402
from flatland_ma.policies.checkpoint import load_checkpoint  # noqa: E402
from tests.interrupted import stopped_at  # noqa: E402

STEPS = 50
"""Agent-steps per update: one world of one agent, 50 steps a rollout; the first
stage's episodes last 50 steps, the second's 100."""


def _stream(tmp_path: Path, until: str, first_steps: int = 1000, last_steps: int = 200) -> Path:
    path = tmp_path / "gated.yaml"
    path.write_text(
        "tasks:\n"
        "  - {name: first, scenario: fruits_poisons, overrides: {episode: {max_steps: 50}},"
        f" steps: {first_steps}{until}}}\n"
        "  - {name: last, scenario: fruits_poisons, overrides: {episode: {max_steps: 100}},"
        f" steps: {last_steps}}}\n"
    )
    return path


def _args(tmp_path: Path, stream: Path, **options) -> ppo.Args:
    base = ppo.Args(
        scenario="fruits_poisons",
        curriculum=str(stream),
        num_envs=1,
        num_steps=STEPS,
        checkpoint_every=0,
        tensorboard=False,
        csv=str(tmp_path / "seed_0.csv"),
    )
    return replace(base, **options)


def _episode_ends(tmp_path: Path) -> list[int]:
    rows = (tmp_path / "seed_0.csv").read_text().splitlines()[1:]
    return [int(row.split(",")[2]) for row in rows]


def _stage(until: float | None, over: int = 3, steps: int = 100) -> Stage:
    return Stage("s", None, steps, until=until, over=over)  # type: ignore[arg-type]


def test_the_gate_reads_the_mean_of_the_latest_episodes_and_waits_for_enough_of_them():
    stage = _stage(until=5.0, over=3)
    assert not stage.reached([10.0, 10.0])  # two episodes: too few to judge
    assert stage.reached([10.0, 5.0, 0.0])  # mean 5
    assert not stage.reached([10.0, 5.0, 0.0, 0.0])  # the latest three: mean 5/3
    assert not _stage(until=None).reached([100.0] * 200)  # no gate: the stage lasts its steps


def test_the_steps_an_early_stage_leaves_go_to_the_stages_after_it():
    stages = [_stage(None, steps=100), _stage(None, steps=200), _stage(None, steps=300)]
    assert stage_ends(stages, [0]).tolist() == [100, 300, 600]
    # The first stage ended at 40 (60 unused): every later end comes 60 sooner.
    assert stage_ends(stages, [0, 40]).tolist() == [100, 240, 540]
    # Ended on its steps with a rollout's overshoot: the later ends are unmoved.
    assert stage_ends(stages, [0, 120]).tolist() == [100, 300, 600]
    assert stage_ends(stages, [0, 40, 100]).tolist() == [100, 240, 400]
    record = stages_record(stages, [0, 40, 260])
    assert [r.get("ended_early") for r in record] == [True, False, None]


def test_a_stage_whose_gate_is_reached_ends_and_the_last_stage_gets_its_steps(tmp_path):
    # Any return reaches -1000: the first stage ends after its first two episodes.
    stream = _stream(tmp_path, ", until: {mean_return: -1000, episodes: 2}")
    summary = ppo.main(_args(tmp_path, stream))
    first, last = summary["curriculum"]
    assert first == {"name": "first", "began": 0, "until": -1000.0, "ended_early": True}
    ends = _episode_ends(tmp_path)
    # The next stage began with the end of the rollout in which the second episode ended
    # (a world's reset step acts for nobody, so rollouts end a step sooner after each).
    assert ends[:2] == [50, 100] and ends[1] <= last["began"] < ends[1] + STEPS
    assert last == {"name": "last", "began": last["began"]}
    # Then the second stage's episodes of 100 steps until the budget's end: the run's
    # 24 rollouts of 50 slot-steps (the stages' sum), less one reset step an episode.
    assert np.diff([last["began"], *ends[2:]]).tolist() == [100] * (len(ends) - 2)
    assert summary["steps"] + len(ends) == 1200 and ends[-1] > 1100


def test_a_gate_never_reached_lets_the_stage_last_its_steps(tmp_path):
    stream = _stream(tmp_path, ", until: {mean_return: 1000000, episodes: 2}", first_steps=200)
    summary = ppo.main(_args(tmp_path, stream))
    first, last = summary["curriculum"]
    assert first["ended_early"] is False and 200 <= last["began"] < 200 + STEPS
    ends = _episode_ends(tmp_path)
    assert ends[:4] == [50, 100, 150, 200]
    assert np.diff([last["began"], *ends[4:]]).tolist() == [100] * (len(ends) - 4)


def test_a_resumed_curriculum_goes_on_in_the_stage_it_had_begun(tmp_path, monkeypatch):
    stream = _stream(tmp_path, ", until: {mean_return: -1000, episodes: 2}", first_steps=400)
    args = _args(tmp_path, stream, checkpoint_every=2)
    stopped_at(args, monkeypatch, 7)  # the second stage began at update 4 (148 steps)
    checkpoint = periodic_checkpoints(tmp_path / "seed_0")[-1]
    assert checkpoint.name.startswith("update_00006")
    at = load_checkpoint(checkpoint)[0]["agent_steps"]
    summary = ppo.main(replace(args, resume=True))
    assert summary["resumed_at"] == [at] and summary["steps"] > 550
    first, last = summary["curriculum"]
    assert first["ended_early"] is True and 100 <= last["began"] < 100 + STEPS
    # On from the checkpoint in the second stage's worlds (not the first's again, which
    # its steps, 400, would still give): episodes of 100 steps.
    later = [end for end in _episode_ends(tmp_path) if end > at]
    assert len(later) >= 2 and np.diff([at, *later]).tolist() == [100] * len(later)


def test_until_is_refused_in_a_lifelong_stream_and_on_a_curriculum_s_last_stage(tmp_path):
    stream = _stream(tmp_path, ", until: {mean_return: 5}")
    with pytest.raises(ScenarioError, match=r"gated\.yaml:2.*tasks\[0\]\.until.*curriculum"):
        load_stream(stream)
    last = tmp_path / "last.yaml"
    last.write_text(
        "tasks:\n"
        "  - {name: only, scenario: fruits_poisons, steps: 100,\n"
        "     until: {mean_return: 5}}\n"
    )
    with pytest.raises(ScenarioError, match=r"last\.yaml:3.*nothing to end"):
        curriculum_stages(last)
    with pytest.raises(ScenarioError, match=r"episodes"):
        curriculum_stages(_stream(tmp_path, ", until: {mean_return: 5, episodes: 0}"))
