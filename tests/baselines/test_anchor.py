"""The pull towards the policy a run started from (``baselines.anchor``, ``--anchor W``):
the divergence against its formula, the weight's fade, the options it refuses, and a run
that stays nearer its starting policy with the pull than without it."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

from baselines import ppo  # noqa: E402
from baselines.anchor import Anchor, anchor, divergence  # noqa: E402
from tests.ppo_helpers import tiny_args  # noqa: E402


def _args(folder: Path, **options) -> ppo.Args:
    return tiny_args(folder, **{"num_envs": 2, **options})


def _kl(p, q) -> float:
    return sum(a * math.log(a / b) for a, b in zip(p, q))


def test_the_divergence_is_the_kl_of_each_head_summed_and_averaged_over_rows():
    target = torch.log(torch.tensor([[0.7, 0.2, 0.1, 0.5, 0.5], [0.2, 0.2, 0.6, 0.9, 0.1]]))
    logits = torch.log(torch.tensor([[0.2, 0.3, 0.5, 0.1, 0.9], [0.4, 0.4, 0.2, 0.5, 0.5]]))
    rows = [
        _kl([0.7, 0.2, 0.1], [0.2, 0.3, 0.5]) + _kl([0.5, 0.5], [0.1, 0.9]),
        _kl([0.2, 0.2, 0.6], [0.4, 0.4, 0.2]) + _kl([0.9, 0.1], [0.5, 0.5]),
    ]
    got = divergence(target, logits, (3, 2))
    assert got.item() == pytest.approx(np.mean(rows), rel=1e-5)
    # Logits shifted by a constant per head are the same distribution: no divergence.
    shifted = torch.cat([target[:, :3] + 4.0, target[:, 3:] - 2.0], -1)
    assert divergence(target, shifted, (3, 2)).item() == pytest.approx(0.0, abs=1e-6)


def test_a_gradient_step_on_the_divergence_moves_the_policy_towards_the_target():
    target = torch.tensor([[2.0, -1.0, 0.0]])
    logits = torch.zeros(1, 3, requires_grad=True)
    before = divergence(target, logits, (3,))
    before.backward()
    with torch.no_grad():
        after = divergence(target, logits - 0.5 * logits.grad, (3,))
    assert after.item() < before.item()
    assert logits.grad[0, 0] < 0 < logits.grad[0, 1]  # the likeliest target move gains


class _Reference(torch.nn.Module):
    def eval(self):
        return self


def test_the_weight_fades_over_its_updates_and_a_resumed_run_goes_on_where_it_stood():
    held = Anchor(_Reference(), 2.0, fade_updates=0, calls_per_update=4)
    fading = Anchor(_Reference(), 2.0, fade_updates=10, calls_per_update=4)
    weights = []
    for _ in range(12 * 4):  # twelve updates of four minibatches each
        weights.append(fading.weight_now())
        fading.calls += 1
    assert weights[:4] == [2.0] * 4  # one weight for every minibatch of an update
    assert weights[5 * 4] == pytest.approx(1.0)  # halfway
    assert weights[10 * 4 :] == [0.0] * 8  # faded out and held there
    assert held.weight_now() == 2.0
    resumed = Anchor(_Reference(), 2.0, fade_updates=10, calls_per_update=4, done=5)
    assert resumed.weight_now() == pytest.approx(1.0)


def test_options_the_anchor_does_not_go_with_are_refused(tmp_path):
    ppo.main(_args(tmp_path / "first"))
    source = str(tmp_path / "first" / "seed_0.safetensors")
    ppo.main(_args(tmp_path / "stacked", frames=2))
    stacked = str(tmp_path / "stacked" / "seed_0.safetensors")
    cases = [
        ({"anchor": 1.0}, "--init-from"),
        ({"anchor": -1.0, "init_from": source}, "weight >= 0"),
        ({"anchor": 1.0, "anchor_fade": 1.5, "init_from": source}, r"\[0, 1\]"),
        ({"anchor": 1.0, "init_from": stacked, "frames": 2}, "feed-forward"),
    ]
    for options, message in cases:
        with pytest.raises(ValueError, match=message):
            ppo.main(_args(tmp_path / "refused", **options))


def test_without_the_option_there_is_no_anchor():
    assert anchor(_args(Path("unused")), agent=None, iterations=10) is None


def test_a_run_pulled_towards_its_start_ends_nearer_it(tmp_path):
    """The same run from the same checkpoint, with and without a strong pull: the pulled
    one's policy differs less from the starting one on the same observations, and its
    update reports the divergence."""
    ppo.main(_args(tmp_path / "first", seed=3))
    source = str(tmp_path / "first" / "seed_0.safetensors")
    start = ppo.Training(_args(tmp_path / "probe", init_from=source, anchor=1.0))
    try:
        start.rollout.collect(start.agent, start.env, start.observation, 0.1, lambda *a: None)
        observations = start.rollout.observations
        x = (
            {k: v.flatten(0, 1) for k, v in observations.items()}
            if isinstance(observations, dict)
            else observations.flatten(0, 1)
        )
        with torch.no_grad():
            reference = start.agent.actor(start.agent.features(x))
        stats = start.rollout.learn(start.agent, start.optimizer, start.args)
        assert stats["losses/anchor_kl"] >= 0.0
    finally:
        start.env.close()

    def drift(**options) -> float:
        folder = tmp_path / "_".join(f"{k}{v}" for k, v in options.items())
        args = _args(folder, init_from=source, total_timesteps=64 * 6, seed=5, **options)
        ppo.main(args)
        trained = ppo.Training(replace(args, init_from=str(folder / "seed_0.safetensors")))
        try:
            with torch.no_grad():
                logits = trained.agent.actor(trained.agent.features(x))
            return divergence(reference, logits, trained.agent.sizes).item()
        finally:
            trained.env.close()

    free, pulled = drift(learning_rate=3e-3), drift(learning_rate=3e-3, anchor=50.0)
    assert free > 0.0
    assert pulled < 0.5 * free
