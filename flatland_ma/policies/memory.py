"""What a policy network remembers within an episode: the last frames it saw, and the
state of its recurrent core.

A network with ``frames: K`` reads, for each observation entry, the entry's last K
observations (oldest first) along an axis after the batch's; at an episode's first step
the K frames are all that step's observation (as Gymnasium's ``FrameStackObservation``
with ``padding_type="reset"``). A network with ``memory: "gru"`` carries a hidden state,
zeros at an episode's first step. Both are kept in a ``Memory``, one row per agent (or
slot), and both restart where ``starts`` says an episode begins: the recurrent state is
multiplied by ``1 - starts`` before the step, as CleanRL's ``ppo_atari_lstm`` does with
``1 - done``.

Training stores single frames and rebuilds every step's stack from them
(``stack_indices``), so a rollout holds no copy of a frame per stacked position.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import torch

MEMORIES = ("none", "gru")
"""The recurrent cores a ``PPONetwork`` may have: none, or a one-layer GRU."""


class Memory(NamedTuple):
    """One row per agent: its last frames (``None`` with ``frames: 1``; else a tensor, or
    a dict of tensors for a ``Dict`` observation, each (batch, K, *entry)) and its
    recurrent state (``None`` without a core; else (batch, memory_size))."""

    frames: Any
    hidden: torch.Tensor | None


def each(fn: Callable, observation: Any, *others: Any) -> Any:
    """``fn`` over every entry of an observation (a tensor, or a dict of tensors), with
    the matching entries of ``others``."""
    if isinstance(observation, dict):
        return {key: fn(x, *(o[key] for o in others)) for key, x in observation.items()}
    return fn(observation, *others)


def _rows(mask: torch.Tensor, like: torch.Tensor) -> torch.Tensor:
    """A (batch,) mask shaped to broadcast over ``like``'s rows."""
    return mask.reshape(-1, *[1] * (like.dim() - 1))


def stack_frames(observation: Any, frames: Any, starts: torch.Tensor | None, k: int) -> Any:
    """The last ``k`` frames of each row after ``observation``: ``frames`` (the previous
    stacks, or None at every row's first step) moved on by one, except the rows where
    ``starts`` (batch,) is true, which hold ``observation`` k times."""

    def one(x: torch.Tensor, past: torch.Tensor | None = None) -> torch.Tensor:
        repeated = x.unsqueeze(1).expand(x.shape[0], k, *x.shape[1:])
        if past is None:
            return repeated.clone()
        moved = torch.cat([past[:, 1:], x.unsqueeze(1)], dim=1)
        if starts is None:
            return moved
        return torch.where(_rows(starts.bool(), moved), repeated, moved)

    if frames is None:
        return each(one, observation)
    return each(one, observation, frames)


def restart(hidden: torch.Tensor, starts: torch.Tensor | None) -> torch.Tensor:
    """The recurrent state with the rows where an episode starts set to zeros."""
    if starts is None:
        return hidden
    return hidden * (1.0 - starts.to(hidden.dtype)).unsqueeze(1)


def stack_indices(starts: torch.Tensor, k: int) -> torch.Tensor:
    """Where each step's stack of ``k`` frames comes from, for a rollout of T steps whose
    frames are kept once: ``index[t, b, j]`` is the row of ``[earlier, frames]`` (the
    k - 1 frames of slot ``b``'s stack before the rollout, oldest first, then the T
    frames) that holds frame j of step t's stack (j = k - 1 is step t itself). A frame
    from before the slot's episode began is its first frame instead, as at play.
    ``starts`` (T, slots) says which steps begin an episode."""
    steps, slots = starts.shape
    t = torch.arange(steps).unsqueeze(1).expand(steps, slots)
    # The step at which each step's episode began (-(k - 1): before the rollout).
    began = torch.where(starts.bool(), t, torch.full_like(t, -(k - 1))).cummax(dim=0).values
    lags = torch.arange(k - 1, -1, -1)
    source = torch.maximum(t.unsqueeze(-1) - lags, began.unsqueeze(-1))
    return source + (k - 1)


def gather_stacks(frames: Any, index: torch.Tensor, slots: torch.Tensor) -> Any:
    """The stacks at ``index`` (n, k) (rows of ``stack_indices``) of the slots ``slots``
    (n,): (n, k, *entry) for each entry of ``frames`` (k - 1 + T, slots, *entry), the
    frames of the stacks before the rollout followed by the rollout's."""
    return each(lambda kept: kept[index, slots.unsqueeze(1)], frames)
