"""Starting a ``baselines.ppo`` run from another run's network (``--init-from``): the
weights are the checkpoint's before the first update, the optimiser starts anew, and a
checkpoint that does not fit is refused naming the file."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

from baselines import ppo  # noqa: E402
from flatland_ma.policies.checkpoint import load_checkpoint  # noqa: E402


def _args(folder: Path, **options) -> ppo.Args:
    base = ppo.Args(
        scenario="fruits_poisons",
        num_envs=1,
        num_steps=32,
        total_timesteps=64,
        checkpoint_every=0,
        tensorboard=False,
        hidden=32,
        csv=str(folder / "seed_0.csv"),
    )
    return replace(base, **options)


def test_a_run_started_from_a_checkpoint_holds_its_weights_before_learning(tmp_path):
    ppo.main(_args(tmp_path / "first", seed=3))
    source = tmp_path / "first" / "seed_0.safetensors"
    weights = load_checkpoint(source)[2]["model"]
    fresh = ppo.Training(_args(tmp_path / "fresh"))
    started = ppo.Training(_args(tmp_path / "second", init_from=str(source)))
    try:
        mine = started.agent.state_dict()
        assert all(torch.equal(mine[k], weights[k]) for k in weights)
        assert not all(torch.equal(fresh.agent.state_dict()[k], weights[k]) for k in weights)
        assert not started.optimizer.state  # Adam's moments start anew
    finally:
        for training in (fresh, started):
            training.env.close()


def test_a_checkpoint_that_does_not_fit_is_refused_naming_it(tmp_path):
    ppo.main(_args(tmp_path / "small", hidden=16))
    source = tmp_path / "small" / "seed_0.safetensors"
    with pytest.raises(ValueError, match=r"seed_0\.safetensors: does not fit this run's network"):
        ppo.Training(_args(tmp_path / "big", init_from=str(source)))
    junk = tmp_path / "junk.safetensors"
    junk.write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="junk.safetensors"):
        ppo.Training(_args(tmp_path / "other", init_from=str(junk)))
