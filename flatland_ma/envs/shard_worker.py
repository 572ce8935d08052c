"""What runs in a shard's process, and the arrays it shares with the parent
(``flatland_ma.envs.shards``): its worlds as one ``BatchedParallelEnv``, stepped on
request, the results written into shared memory; the final observations of ``SAME_STEP``
and the info entries that are not numbers go back with the answers."""

from __future__ import annotations

import gymnasium
import numpy as np

from flatland_ma.envs.vector import BatchedParallelEnv


def shared_layout(n: int, space, action, infos: dict) -> dict[str, tuple[tuple, np.dtype]]:
    """Name -> (shape, dtype) of every array shared with the shards, for ``n`` slots of
    observations in ``space``, actions in ``action`` and the entries of ``infos``."""
    arrays: dict[str, tuple[tuple, np.dtype]] = {}
    subspaces = space.spaces if isinstance(space, gymnasium.spaces.Dict) else {None: space}
    for key, sub in subspaces.items():
        assert sub.shape is not None
        arrays[f"obs/{key}" if key is not None else "obs"] = ((n, *sub.shape), np.dtype(sub.dtype))
    assert action.shape is not None
    arrays["actions"] = ((n, *action.shape), np.dtype(action.dtype))
    arrays["rewards"] = ((n,), np.dtype(np.float64))
    for flag in ("terminations", "truncations", "active", "acting"):
        arrays[flag] = ((n,), np.dtype(bool))
    for key, values in infos.items():
        if key != "active" and values.dtype != object and values.ndim == 1:
            arrays[f"info/{key}"] = ((n,), values.dtype)
    return arrays


def views(buffers: dict, layout: dict) -> dict[str, np.ndarray]:
    return {
        name: np.frombuffer(buffers[name], dtype=dtype, count=int(np.prod(shape))).reshape(shape)
        for name, (shape, dtype) in layout.items()
    }


def serve(pipe, scenario, num_worlds, max_cycles, overrides, slots, buffers, layout) -> None:
    """A shard's process: its worlds, stepped on request, results into shared memory."""
    try:  # the shards are the parallelism: one thread each (and forked: none of numba's)
        batch = BatchedParallelEnv(
            scenario,
            num_worlds=num_worlds,
            max_cycles=max_cycles,
            copy=False,
            parallel=False,
            **overrides,
        )
        arrays = {name: view[slots] for name, view in views(buffers, layout).items()}
        pipe.send(("ok", None))
    except Exception as err:  # reported to the parent, which raises it
        pipe.send(("error", f"{type(err).__name__}: {err}"))
        return
    while True:
        try:
            command, payload = pipe.recv()
        except (EOFError, KeyboardInterrupt):
            break
        if command == "close":
            break
        try:
            if command in ("state", "render"):
                pipe.send(("ok", batch.state() if command == "state" else batch.render()))
                continue
            if command == "reset":
                seeds, mask = payload
                options = None if mask is None else {"reset_mask": mask}
                observations, infos = batch.reset(seed=seeds, options=options)
                rewards = terminations = truncations = None
                _clear_flags(arrays, mask, batch.agents_per_world)
            else:
                observations, rewards, terminations, truncations, infos = batch.step(
                    arrays["actions"]
                )
            _write(arrays, observations, rewards, terminations, truncations, infos)
            arrays["acting"][:] = batch.acting()
            objects = {k: list(v) for k, v in infos.items() if object_info(v) and k != "final_obs"}
            finals = {}
            if "_final_obs" in infos:
                final_info = infos["final_info"]
                for slot in np.flatnonzero(infos["_final_obs"]):
                    counted = {key: values[slot] for key, values in final_info.items()}
                    finals[int(slot)] = (infos["final_obs"][slot], counted)
            pipe.send(("ok", (objects, finals)))
        except Exception as err:
            pipe.send(("error", f"{type(err).__name__}: {err}"))
    batch.close()


def _write(arrays, observations, rewards, terminations, truncations, infos) -> None:
    if isinstance(observations, dict):
        for key, values in observations.items():
            arrays[f"obs/{key}"][:] = values
    else:
        arrays["obs"][:] = observations
    if rewards is not None:
        arrays["rewards"][:] = rewards
        arrays["terminations"][:] = terminations
        arrays["truncations"][:] = truncations
    for key, values in infos.items():
        if key == "active":
            arrays["active"][:] = values
        elif f"info/{key}" in arrays:
            arrays[f"info/{key}"][:] = values


def object_info(values) -> bool:
    """Whether an info entry goes with the answers rather than through shared memory."""
    return isinstance(values, np.ndarray) and values.dtype == object and values.ndim == 1


def _clear_flags(arrays, mask, agents_per_world: int) -> None:
    """Zero the rewards and flags of the slots of the worlds reset (all, without a mask)."""
    slots = slice(None) if mask is None else np.repeat(mask, agents_per_world)
    for name, value in (("rewards", 0.0), ("terminations", False), ("truncations", False)):
        arrays[name][slots] = value
