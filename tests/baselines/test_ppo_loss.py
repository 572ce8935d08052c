"""The PPO loss's advantages: normalised over the minibatch by default (CleanRL's), taken as
they are with ``--no-norm-adv`` (the run records it: ``test_ppo_init.py``)."""

from __future__ import annotations

import pytest

torch = pytest.importorskip("torch")

from baselines.ppo_loss import ppo_loss  # noqa: E402


def _policy_loss(advantage: torch.Tensor, normalise: bool) -> tuple[float, torch.Tensor]:
    """The policy part of the loss and its gradient by the new log-probabilities, at a
    ratio of one (nothing clipped), with the value and entropy terms off."""
    n = advantage.shape[0]
    new_logprob = torch.zeros(n, requires_grad=True)
    zeros = torch.zeros(n)
    loss, parts = ppo_loss(
        0.2,
        0.0,
        0.0,
        new_logprob,
        zeros,
        zeros,
        zeros,
        advantage,
        zeros,
        zeros,
        normalise=normalise,
    )
    loss.backward()
    assert new_logprob.grad is not None
    return float(parts["losses/policy"]), new_logprob.grad


def test_normalised_advantages_ignore_their_scale_and_offset():
    advantage = torch.tensor([0.5, -1.0, 2.0, 0.25])
    loss, grad = _policy_loss(advantage, normalise=True)
    loss_scaled, grad_scaled = _policy_loss(advantage * 100 + 7, normalise=True)
    assert loss == pytest.approx(0.0, abs=1e-6)  # a normalised minibatch's mean is 0
    assert torch.allclose(grad, grad_scaled, atol=1e-6)
    assert loss_scaled == pytest.approx(0.0, abs=1e-4)


def test_raw_advantages_give_steps_in_proportion_to_them():
    advantage = torch.tensor([0.5, -1.0, 2.0, 0.25])
    loss, grad = _policy_loss(advantage, normalise=False)
    # L = -mean(A * ratio) at ratio 1, dL/dlogprob_i = -A_i / n
    assert loss == pytest.approx(-float(advantage.mean()))
    assert torch.allclose(grad, -advantage / 4)
    _, small_grad = _policy_loss(advantage / 1000, normalise=False)
    assert torch.allclose(small_grad, grad / 1000)
    # the same small advantages, normalised, step as far as the large ones
    assert torch.allclose(
        _policy_loss(advantage / 1000, normalise=True)[1],
        _policy_loss(advantage, normalise=True)[1],
        atol=1e-5,
    )
