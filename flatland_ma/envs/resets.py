"""When the worlds of the batched envs reset: Gymnasium 1.x's three autoreset modes.

``autoreset_mode=`` on ``BatchedParallelEnv``, ``ShardedParallelEnv`` and
``gymnasium.make_vec`` takes a ``gymnasium.vector.AutoresetMode`` (or its name or value,
in any case: ``"same_step"``, ``"SameStep"``); the env declares it in
``metadata["autoreset_mode"]`` and as its ``autoreset_mode`` attribute (which TorchRL
reads). A world's episode ends when its last
agent finishes (terminated or truncated). Then:

- ``NEXT_STEP``: the next step resets the world instead of stepping it (its actions are
  not used) and returns the first observation of its new episode with reward 0 and neither
  termination nor truncation. The default of ``BatchedParallelEnv`` and
  ``ShardedParallelEnv``.
- ``SAME_STEP``: the step in which the episode ends also resets the world: its slots hold
  the new episode's first observation, beside the final step's rewards, terminations and
  truncations. What the finished agents saw last is in ``infos["final_obs"]`` (an object
  array, one entry per slot, None where none finished) and their counters in
  ``infos["final_info"]``, with ``infos["_final_obs"]`` / ``infos["_final_info"]`` saying
  which slots have them: Gymnasium's keys and shapes (``SyncVectorEnv``). In the batched
  env every slot that finished in the step has them, also an agent that finished while its
  world plays on (its last observation is then in the observations too). The default of
  ``gymnasium.make_vec``, since TorchRL takes only ``SAME_STEP`` or ``DISABLED``.
- ``DISABLED``: nothing resets by itself; ``reset(options={"reset_mask": mask})`` resets
  the worlds whose entry of ``mask`` (a bool array, one per world) is True, each with its
  seed (``seed + w``, or ``seed[w]``, or fresh entropy). Stepping a world whose episode is
  over raises ``RuntimeError`` and changes nothing.

``reset(options={"reset_mask": mask})`` works in every mode.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode

from flatland_ma.envs.buffers import counter_array
from flatland_ma.envs.flatten import FlatLayout

RESET_MASK = "reset_mask"
"""The key of ``reset``'s options that says which worlds to reset (Gymnasium's)."""
FINAL_OBS, FINAL_INFO = "final_obs", "final_info"
"""The info keys of ``SAME_STEP``'s last observations and counters (Gymnasium's)."""


def autoreset_mode_of(mode: Any) -> AutoresetMode:
    """``mode`` as an ``AutoresetMode``, or a ``ValueError`` listing the modes."""
    if isinstance(mode, AutoresetMode):
        return mode
    for known in AutoresetMode:
        if isinstance(mode, str) and mode.replace("-", "_").upper() in (
            known.name,
            known.value.upper(),
        ):
            return known
    else:
        names = ", ".join(f"{m.name} ({m.value!r})" for m in AutoresetMode)
        raise ValueError(f"autoreset_mode must be one of {names}, not {mode!r}") from None


def reset_mask_of(options: dict | None, num_worlds: int) -> np.ndarray | None:
    """The checked ``reset_mask`` of ``reset``'s options (one bool per world, at least one
    True), or None if there is none (every world resets)."""
    if options is None or RESET_MASK not in options:
        return None
    mask = options[RESET_MASK]
    if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_:
        raise TypeError(
            f"options['reset_mask'] must be a numpy array of bools, one per world, not {mask!r}"
        )
    if mask.shape != (num_worlds,):
        raise ValueError(
            f"options['reset_mask'] must have shape ({num_worlds},), one entry per world, "
            f"not {mask.shape}"
        )
    if not mask.any():
        raise ValueError("options['reset_mask'] resets no world: give at least one True")
    return mask


def flatten_into(layout: FlatLayout, buffer, out: np.ndarray) -> np.ndarray:
    """Write stacked observations ``buffer`` (an array, or a dict of arrays for a ``Dict``
    space, with one leading slot axis) into ``out`` (slots x the flat size), part by part
    in ``layout``'s order; returns ``out``."""
    n = out.shape[0]
    for part in layout.parts:
        values = buffer if not isinstance(buffer, dict) else buffer[part.name]
        out[:, part.start : part.stop] = values.reshape(n, -1)
    return out


def slot_of(buffer, slot: int):
    """A copy of one slot's observation from stacked observations."""
    if isinstance(buffer, dict):
        return {key: values[slot].copy() for key, values in buffer.items()}
    return buffer[slot].copy()


def final_infos(
    finals: dict[int, tuple[Any, dict]], counters: dict[str, np.ndarray], n: int
) -> dict:
    """``SAME_STEP``'s info entries for the slots in ``finals`` (slot -> last observation
    and counters), with ``n`` slots: ``final_obs`` / ``final_info`` and their masks. Empty
    when no slot finished (Gymnasium adds the keys only then)."""
    if not finals:
        return {}
    observations = np.full(n, None, object)
    mask = np.zeros(n, bool)
    info = {key: np.zeros(n, values.dtype) for key, values in counters.items()}
    for key, values in counters.items():
        if values.dtype == object:
            info[key] = np.full(n, None, object)
    for slot, (observation, counted) in finals.items():
        observations[slot] = observation
        mask[slot] = True
        for key, value in counted.items():
            if key not in info:  # a counter the slots' current episodes lack
                info[key] = counter_array(value, n)
            info[key][slot] = value
    return {
        FINAL_OBS: observations,
        f"_{FINAL_OBS}": mask,
        FINAL_INFO: info,
        f"_{FINAL_INFO}": mask.copy(),
    }
