"""CleanRL's PPO loss on one minibatch, for updates that gather their minibatches their
own way (``baselines.ppo_memory``'s sequences of slots, or steps with their frames)."""

from __future__ import annotations

import torch
from torch import nn


def ppo_loss(
    clip_coef: float,
    vf_coef: float,
    ent_coef: float,
    new_logprob: torch.Tensor,
    entropy: torch.Tensor,
    new_value: torch.Tensor,
    logprob: torch.Tensor,
    advantage: torch.Tensor,
    returns: torch.Tensor,
    value: torch.Tensor,
    normalise: bool = True,
) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """The loss of the minibatch's entries and its parts (the names of
    ``baselines.ppo.update``'s statistics):
        L = -min(ratio A, clip(ratio, 1 - eps, 1 + eps) A)
            + vf_coef * 1/2 max((V - R)^2, (V_old + clip(V - V_old, -eps, eps) - R)^2)
            - ent_coef * H,   ratio = pi(a|s) / pi_old(a|s)
    with the advantages A normalised over the minibatch (unless not ``normalise``)."""
    log_ratio = new_logprob - logprob
    ratio = log_ratio.exp()
    if normalise:
        advantage = (advantage - advantage.mean()) / (advantage.std() + 1e-8)
    policy_loss = torch.max(
        -advantage * ratio, -advantage * ratio.clamp(1 - clip_coef, 1 + clip_coef)
    ).mean()
    clipped = value + (new_value - value).clamp(-clip_coef, clip_coef)
    value_loss = 0.5 * torch.max((new_value - returns).square(), (clipped - returns).square())
    value_loss = value_loss.mean()
    loss = policy_loss + vf_coef * value_loss - ent_coef * entropy.mean()
    with torch.no_grad():
        parts = {
            "losses/policy": policy_loss.detach(),
            "losses/value": value_loss.detach(),
            "losses/entropy": entropy.mean(),
            "losses/approx_kl": ((ratio - 1) - log_ratio).mean(),
            "losses/clip_fraction": ((ratio - 1).abs() > clip_coef).float().mean(),
        }
    return loss, parts


def descend(
    agent, optimizer, args, decided, old, penalty=None, extra=None
) -> dict[str, torch.Tensor]:
    """One gradient step on a minibatch: ``ppo_loss`` of what the network now ``decided``
    (log-probabilities, entropies, values) against the rollout's ``old`` (log-probabilities,
    advantages, returns, values), plus ``penalty()`` if given (e.g. EWC's pull towards
    earlier tasks' parameters) and the minibatch's own ``extra`` loss if given (the
    channel's biases); gradients clipped to ``args.max_grad_norm``. Returns the loss's
    parts."""
    loss, parts = ppo_loss(
        args.clip_coef, args.vf_coef, args.ent_coef, *decided, *old, normalise=args.norm_adv
    )
    if penalty is not None:
        loss = loss + penalty()
    if extra is not None:
        loss = loss + extra
    optimizer.zero_grad(set_to_none=True)
    loss.backward()
    nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
    optimizer.step()
    return parts
