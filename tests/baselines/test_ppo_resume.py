"""Going on with an interrupted ``baselines.ppo`` run (``--resume``): the newest periodic
checkpoint's network, optimiser and counts, the log's rows up to it, the whole budget
trained, the same run from the same checkpoint twice, other arguments refused, and the
older periodic checkpoints pruned."""

from __future__ import annotations

import csv
import json
import shutil
from dataclasses import replace
from pathlib import Path

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

from baselines import ppo  # noqa: E402
from baselines.networks import Agent  # noqa: E402
from baselines.ppo_resume import Resumed, periodic_checkpoints  # noqa: E402
from flatland_ma.policies.checkpoint import load_checkpoint  # noqa: E402
from tests.interrupted import stopped_at  # noqa: E402

STEPS = 32
"""Agent-steps per update: one world of one agent, 32 steps a rollout."""


def _args(folder: Path, **options) -> ppo.Args:
    base = ppo.Args(
        scenario="fruits_poisons",
        num_envs=1,
        num_steps=STEPS,
        total_timesteps=8 * STEPS,
        checkpoint_every=2,
        tensorboard=False,
        csv=str(folder / "seed_0.csv"),
    )
    return replace(base, **options)


def _interrupted(folder: Path, monkeypatch, at: int = 6, **options) -> ppo.Args:
    """A run stopped as it began update ``at`` (its checkpoints of updates 2 and 4 on disk)."""
    args = _args(folder, **options)
    stopped_at(args, monkeypatch, at)
    return args


def _rows(path: Path) -> list[list[str]]:
    with open(path, newline="") as f:
        return [row[:-1] for row in csv.reader(f)]  # without the wall time


def test_a_resumed_run_goes_on_from_its_newest_checkpoint_for_the_whole_budget(
    tmp_path, monkeypatch
):
    args = _interrupted(tmp_path, monkeypatch)
    part = tmp_path / "seed_0.csv.part"
    checkpoint = periodic_checkpoints(tmp_path / "seed_0")[-1]
    assert checkpoint.name.startswith("update_00004")
    info, network, _ = load_checkpoint(checkpoint)
    assert info["agent_steps"] == 4 * STEPS and info["progress"]["resumed_at"] == []
    before = _rows(part)
    summary = ppo.main(replace(args, resume=True))
    assert summary["steps"] == 8 * STEPS and summary["resumed_at"] == [4 * STEPS]
    assert summary["cpu_seconds"] >= info["progress"]["cpu_seconds"] > 0
    after = _rows(tmp_path / "seed_0.csv")
    kept = [row for row in before[1:] if int(row[2]) <= 4 * STEPS]
    assert after[: 1 + len(kept)] == [before[0], *kept]  # the rows up to the checkpoint
    assert all(int(row[2]) > 4 * STEPS for row in after[1 + len(kept) :])
    episodes = [int(row[1]) for row in after[1:]]
    assert episodes == list(range(len(episodes)))  # counted on, not from 0
    # It started from the checkpoint's network: the final one moved on from it.
    final, _, _ = load_checkpoint(tmp_path / "seed_0.safetensors")
    assert final["update"] == 8 and final["progress"]["resumed_at"] == [4 * STEPS]
    assert network is not None


def test_resumed_twice_from_one_checkpoint_it_is_the_same_run(tmp_path, monkeypatch):
    runs = []
    first = tmp_path / "a"
    _interrupted(first, monkeypatch)
    second = tmp_path / "b"
    shutil.copytree(first, second)
    for folder in (first, second):
        ppo.main(replace(_args(folder), resume=True))
        weights = load_checkpoint(folder / "seed_0.safetensors")[2]["model"]
        runs.append((_rows(folder / "seed_0.csv"), weights))
    assert runs[0][0] == runs[1][0]
    assert all(torch.equal(runs[0][1][k], runs[1][1][k]) for k in runs[0][1])


def test_without_a_checkpoint_resume_starts_the_run_and_other_arguments_are_refused(
    tmp_path, monkeypatch
):
    fresh = ppo.main(replace(_args(tmp_path / "fresh"), resume=True, total_timesteps=2 * STEPS))
    assert "resumed_at" not in fresh and fresh["steps"] == 2 * STEPS
    args = _interrupted(tmp_path, monkeypatch)
    with pytest.raises(
        ValueError, match=r"update_00004.*other arguments: ent_coef 0\.01 \(now 0\.02\)"
    ):
        ppo.main(replace(args, resume=True, ent_coef=0.02))
    # Refused before anything changed: the log and the checkpoints are as they were.
    assert (tmp_path / "seed_0.csv.part").is_file()
    assert len(periodic_checkpoints(tmp_path / "seed_0")) == 2


def test_only_the_newest_periodic_checkpoints_are_kept_when_asked(tmp_path):
    ppo.main(_args(tmp_path, keep_checkpoints=1))
    assert [p.name for p in periodic_checkpoints(tmp_path / "seed_0")] == [
        "update_00008.safetensors"
    ]
    summary = json.loads((tmp_path / "seed_0.json").read_text())
    assert summary["steps"] == 8 * STEPS


def test_each_resumed_update_seeds_its_worlds_apart():
    # (the stage a resumed curriculum goes on in: tests/baselines/test_curriculum_until.py)
    resumed = Resumed(Path("x"), 5, 250, 3, 1.0, 1.0, [250], [0, 200], {})
    assert resumed.seed(7) != resumed.seed(8) and resumed.seed(7) != replace(
        resumed, update=6
    ).seed(7)


def test_an_option_newer_than_the_checkpoint_counts_as_left_at_its_default(tmp_path, monkeypatch):
    args = _interrupted(tmp_path, monkeypatch)
    path = periodic_checkpoints(tmp_path / "seed_0")[-1]
    from flatland_ma.policies.checkpoint import read_checkpoint

    saved = read_checkpoint(path)["args"]
    assert Resumed.find(args, tmp_path / "seed_0").update == 4
    older = {k: v for k, v in saved.items() if k != "frames"}  # as if written before it
    monkeypatch.setattr(
        "baselines.ppo_resume.load_checkpoint",
        lambda p: (lambda info, net, state: ({**info, "args": older}, net, state))(
            *load_checkpoint(p)
        ),
    )
    assert Resumed.find(args, tmp_path / "seed_0").update == 4
    with pytest.raises(ValueError, match=r"frames 1 \(now 4\)"):
        Resumed.find(replace(args, frames=4), tmp_path / "seed_0")


def test_a_finished_run_asked_to_go_on_keeps_its_log(tmp_path):
    args = _args(tmp_path)
    first = ppo.main(args)
    rows = _rows(tmp_path / "seed_0.csv")
    again = ppo.main(replace(args, resume=True))  # its newest checkpoint is its last update
    assert again["steps"] == first["steps"] == 8 * STEPS and again["resumed_at"] == [8 * STEPS]
    assert _rows(tmp_path / "seed_0.csv") == rows


def test_a_checkpoint_that_does_not_fit_the_network_is_refused_naming_it(tmp_path, monkeypatch):
    args = _interrupted(tmp_path, monkeypatch)
    found = Resumed.find(args, tmp_path / "seed_0")
    assert found is not None
    other = Agent(*_spaces(args), hidden=8)
    optimizer = torch.optim.Adam(other.parameters())
    with pytest.raises(
        ValueError, match=r"update_00004\.safetensors: does not fit this run's network"
    ):
        found.load(other, optimizer)


def _spaces(args):
    from flatland_ma.envs.vector import BatchedParallelEnv

    env = BatchedParallelEnv(args.scenario, num_worlds=1, pad=True)
    try:
        return env.single_observation_space, env.single_action_space
    finally:
        env.close()


def test_a_log_that_is_not_the_runs_is_refused_and_left_as_it_was(tmp_path, monkeypatch):
    args = _interrupted(tmp_path, monkeypatch)
    part = tmp_path / "seed_0.csv.part"
    part.write_bytes(b"\xff\xfe not a log")
    with pytest.raises(ValueError, match=r"seed_0\.csv\.part: not a log this run can go on with"):
        ppo.main(replace(args, resume=True))
    assert part.read_bytes() == b"\xff\xfe not a log"
    part.write_text("seed,episode,step,agent,other\n")
    with pytest.raises(ValueError, match=r"\(other columns\)"):
        ppo.main(replace(args, resume=True))
    assert part.read_text() == "seed,episode,step,agent,other\n"
