"""Starting a ``baselines.ppo`` run from another run's network (``--init-from``): the
weights are the checkpoint's before the first update, the optimiser starts anew, and a
checkpoint that does not fit is refused naming the file."""

from __future__ import annotations

import json

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

from baselines import ppo  # noqa: E402
from flatland_ma.policies.checkpoint import load_checkpoint  # noqa: E402
from tests.ppo_helpers import tiny_args  # noqa: E402


def test_a_run_started_from_a_checkpoint_holds_its_weights_before_learning(tmp_path):
    ppo.main(tiny_args(tmp_path / "first", seed=3))
    source = tmp_path / "first" / "seed_0.safetensors"
    weights = load_checkpoint(source)[2]["model"]
    fresh = ppo.Training(tiny_args(tmp_path / "fresh"))
    started = ppo.Training(tiny_args(tmp_path / "second", init_from=str(source)))
    try:
        mine = started.agent.state_dict()
        assert all(torch.equal(mine[k], weights[k]) for k in weights)
        assert not all(torch.equal(fresh.agent.state_dict()[k], weights[k]) for k in weights)
        assert not started.optimizer.state  # Adam's moments start anew
    finally:
        for training in (fresh, started):
            training.env.close()


def test_a_checkpoint_that_does_not_fit_is_refused_naming_it(tmp_path):
    ppo.main(tiny_args(tmp_path / "small", hidden=16))
    source = tmp_path / "small" / "seed_0.safetensors"
    with pytest.raises(ValueError, match=r"seed_0\.safetensors: does not fit this run's network"):
        ppo.Training(tiny_args(tmp_path / "big", init_from=str(source)))
    junk = tmp_path / "junk.safetensors"
    junk.write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="junk.safetensors"):
        ppo.Training(tiny_args(tmp_path / "other", init_from=str(junk)))


def test_critic_warmup_trains_the_critic_alone_then_everything(tmp_path):
    """``--critic-warmup N``: the first N updates move the critic's head and nothing else
    (the policy acts as the checkpoint did); the updates after move the rest too."""
    ppo.main(tiny_args(tmp_path / "first", seed=3))
    source = str(tmp_path / "first" / "seed_0.safetensors")
    weights = load_checkpoint(source)[2]["model"]

    def after(updates: int, warmup: int) -> dict:
        folder = tmp_path / f"warm_{updates}_{warmup}"
        ppo.main(
            tiny_args(folder, init_from=source, critic_warmup=warmup, total_timesteps=32 * updates)
        )
        return load_checkpoint(folder / "seed_0.safetensors")[2]["model"]

    def moved(model: dict) -> set[str]:
        return {k for k in weights if not torch.equal(model[k], weights[k])}

    critic = {k for k in weights if k.startswith("critic.")}
    assert critic and moved(after(2, warmup=2)) == critic
    assert moved(after(3, warmup=2)) > critic  # the third update trains the whole network
    assert moved(after(2, warmup=0)) > critic


def test_critic_warmup_is_refused_with_overlap(tmp_path):
    with pytest.raises(ValueError, match="--critic-warmup"):
        ppo.main(tiny_args(tmp_path / "x", critic_warmup=1, overlap=True))
    with pytest.raises(ValueError, match="--critic-warmup"):
        ppo.main(tiny_args(tmp_path / "y", critic_warmup=-1))


def test_no_norm_adv_is_an_option_of_the_run(tmp_path):
    ppo.main(tiny_args(tmp_path, norm_adv=False))
    summary = json.loads((tmp_path / "seed_0.json").read_text())
    assert summary["args"]["norm_adv"] is False
