"""The batched env's worlds spread over processes, to use every core.

``ShardedParallelEnv(scenario, num_worlds, shards=K)`` has the interface of
``BatchedParallelEnv`` and returns exactly what it returns for the same seeds and actions:
the worlds are split into K contiguous groups, each a ``BatchedParallelEnv`` in a process
of its own, and world ``w`` is still seeded ``seed + w``.
Actions, observations, rewards, terminations, truncations, the ``active`` flags and the
numeric episode counters pass through shared memory; a step sends each process one short
message and waits for its answer. Info entries that are not numbers (the tuple of keys an
agent holds) come back with the answers.

Every action is checked in this process before any shard moves, so a bad one raises the
batched env's error and changes nothing anywhere. ``flatten``, ``autoreset_mode`` (the
final observations of ``SAME_STEP`` come back with the answers; a ``reset_mask`` is sent to
the shards that hold a world to reset) and ``render_mode="rgb_array"`` (each shard sends
its worlds' frames) work as in ``BatchedParallelEnv``. If a shard's process dies, the next call
raises ``RuntimeError`` naming it; ``close()`` stops them all.

Its size (the worlds, and the processes) is held to the work budget before any process
starts or any shared array is allocated (``flatland_ma.scenario.budget.check_batch``), and
one thread at a time may call it: a second thread calling in meanwhile gets a
``RuntimeError`` (two would take each other's answers from the pipes and wait for ever).

The processes start the platform's default way unless ``context`` names one ("fork",
"forkserver", "spawn"); with "spawn" or "forkserver" the script that makes the env needs
Python's ``if __name__ == "__main__":`` guard.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from typing import Any

import gymnasium
import numpy as np

from flatland_ma.envs.buffers import world_seeds
from flatland_ma.envs.guards import OneCaller, check_batch_of_actions
from flatland_ma.envs.resets import final_infos, reset_mask_of
from flatland_ma.envs.shard_worker import object_info, serve, shared_layout, views
from flatland_ma.envs.vector import (
    AUTORESET_MODE,
    VECTOR_RENDER_MODES,
    BatchedParallelEnv,
    check_vector_render_mode,
)
from flatland_ma.scenario.budget import check_batch

STARTUP_SECONDS = 300.0
"""How long a shard may take to build its worlds before the env gives up on it."""


class ShardedParallelEnv:
    """``num_worlds`` worlds of ``scenario`` in ``shards`` processes (default: one per
    core, at most one per world); see the module's docstring. ``copy=False`` returns the
    shared arrays themselves, overwritten by the next ``step`` or ``reset``."""

    metadata = {"autoreset_mode": AUTORESET_MODE, "render_modes": VECTOR_RENDER_MODES}

    def __init__(
        self,
        scenario: Any = "fruits_poisons",
        num_worlds: int = 1,
        shards: int | None = None,
        max_cycles: int | None = None,
        copy: bool = True,
        context: str | None = None,
        *,
        _counted_as: str = "num_worlds",
        **overrides,
    ):
        if isinstance(num_worlds, bool) or not isinstance(num_worlds, int) or num_worlds < 1:
            raise ValueError(f"{_counted_as} must be a positive integer, not {num_worlds!r}")
        if shards is not None and (
            isinstance(shards, bool) or not isinstance(shards, int) or shards < 1
        ):
            raise ValueError(f"shards must be a positive integer, not {shards!r}")
        self._guard = OneCaller("this sharded env")
        self._pipes, self._processes = [], []
        check_vector_render_mode(overrides.get("render_mode"))
        # One world here, to check the arguments, learn the spaces and lay out the arrays.
        probe = BatchedParallelEnv(scenario, num_worlds=1, max_cycles=max_cycles, **overrides)
        shards = min(num_worlds, shards if shards is not None else os.cpu_count() or 1)
        check_batch(probe.spec, num_worlds, _counted_as, processes=shards)
        self.num_worlds, self.num_shards, self.copy = num_worlds, shards, copy
        self._learn(probe)
        processes = mp.get_context(context)
        self._share(processes, probe)
        bounds = np.linspace(0, num_worlds, shards + 1).round().astype(int)
        self._worlds = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]
        m = self.agents_per_world
        self._slots = [slice(a * m, b * m) for a, b in self._worlds]
        self._acting = np.zeros(self.num_slots, bool)
        self._finals: dict[int, tuple] = {}
        self._ready = False
        try:
            for k in range(shards):
                self._start(k, processes, scenario, max_cycles, overrides)
            for k in range(shards):
                self._answer(k, STARTUP_SECONDS)
        except BaseException:
            self.close()
            raise

    def _learn(self, probe: BatchedParallelEnv) -> None:
        """The spaces, modes and layout of the worlds, as a batch of one world has them."""
        self.autoreset_mode = probe.autoreset_mode
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        self.render_mode = probe.render_mode
        self._flat = probe.flat
        self.spec = probe.spec
        self.possible_agents = probe.possible_agents
        self.agents_per_world = probe.agents_per_world
        self.num_slots = self.num_worlds * self.agents_per_world
        self.single_observation_space = probe.single_observation_space
        self.single_action_space = probe.single_action_space
        self.padding = probe.padding
        """How observations are padded to one space (``pad=True``), or None."""
        self.single_state_space = probe.single_state_space
        batch_space = gymnasium.vector.utils.batch_space
        self.state_space = batch_space(probe.single_state_space, self.num_worlds)
        self.observation_space = batch_space(self.single_observation_space, self.num_slots)
        self.action_space = batch_space(self.single_action_space, self.num_slots)
        self._checker = probe.worlds[0]

    def _share(self, processes, probe: BatchedParallelEnv) -> None:
        """The arrays shared with the shards, laid out for the counters the probe gives."""
        _, probe_infos = probe.reset(seed=0)
        self._counter_types = {k: v[:0] for k, v in probe_infos.items() if k != "active"}
        self._layout = shared_layout(
            self.num_slots, self.single_observation_space, self.single_action_space, probe_infos
        )
        self._objects = [k for k, v in probe_infos.items() if object_info(v)]
        self._buffers = {
            name: processes.RawArray("b", max(1, int(np.prod(shape)) * dtype.itemsize))
            for name, (shape, dtype) in self._layout.items()
        }
        self._arrays = views(self._buffers, self._layout)
        self._object_infos = {k: np.empty(self.num_slots, object) for k in self._objects}

    def _start(self, k: int, processes, scenario, max_cycles, overrides) -> None:
        """Start shard ``k``'s process over its worlds."""
        first, last = self._worlds[k]
        ours, theirs = processes.Pipe()
        process = processes.Process(  # type: ignore[attr-defined]
            target=serve,
            args=(
                theirs,
                scenario,
                last - first,
                max_cycles,
                overrides,
                self._slots[k],
                self._buffers,
                self._layout,
            ),
            name=f"flatland_ma-shard-{k}",
            daemon=True,
        )
        process.start()
        theirs.close()
        self._pipes.append(ours)
        self._processes.append(process)

    # -- the loop -----------------------------------------------------------------------

    def reset(self, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every world: world ``w`` with ``seed + w`` (or ``seed[w]``); with
        ``options={"reset_mask": mask}`` only those whose entry of ``mask`` is True."""
        with self._guard:
            return self._reset(seed, reset_mask_of(options, self.num_worlds))

    def _reset(self, seed, mask: np.ndarray | None = None):
        seeds = world_seeds(seed, self.num_worlds)
        if mask is not None and not self._ready:
            raise RuntimeError("call reset() without a reset_mask first")
        asked = []
        for k, (first, last) in enumerate(self._worlds):
            own = None if mask is None else mask[first:last]
            if own is None or own.any():
                self._send(k, ("reset", (seeds[first:last], own)))
                asked.append(k)
        self._collect(asked)
        self._ready = True
        return self._results()[0], self._infos()

    def step(self, actions):
        """One step of every world, as ``BatchedParallelEnv.step``."""
        with self._guard:
            return self._step(actions)

    def _step(self, actions):
        if not self._ready:
            raise RuntimeError("call reset() first")
        m = self.agents_per_world
        over = np.flatnonzero(~self._acting.reshape(self.num_worlds, m).any(axis=1))
        if self.autoreset_mode == gymnasium.vector.AutoresetMode.DISABLED and len(over):
            raise RuntimeError(
                f"the episodes of worlds {over.tolist()} are over and autoreset_mode is "
                'DISABLED: reset them first with reset(options={"reset_mask": mask})'
            )
        layout = f"{self.num_worlds} worlds x {self.agents_per_world} agents"
        check_batch_of_actions(actions, self.num_slots, self.single_action_space, layout)
        target = self._arrays["actions"]
        if self._plainly_valid(actions):
            np.copyto(target, actions, casting="unsafe")
        else:
            checked = self._check(actions)
            for slot, action in checked.items():
                target[slot] = action
        for k in range(self.num_shards):
            self._send(k, ("step", None))
        self._collect()
        infos = self._infos()
        infos.update(final_infos(self._finals, self._counter_types, self.num_slots))
        return (*self._results(), infos)

    def render(self) -> tuple | None:
        """With ``render_mode="rgb_array"``: every world's frame, in world order."""
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without a render_mode; nothing to draw")
            return None
        with self._guard:
            if not self._ready:
                raise RuntimeError("call reset() before render()")
            for k in range(self.num_shards):
                self._send(k, ("render", None))
            return tuple(frame for k in range(self.num_shards) for frame in self._answer(k))

    def flat_layout(self):
        """With ``flatten=True``: as ``BatchedParallelEnv.flat_layout``."""
        return self._flat_layout().parts

    def unflatten(self, vector):
        """With ``flatten=True``: one slot's flat observation as it is without flattening."""
        return self._flat_layout().unflatten(vector)

    def _flat_layout(self):
        if self._flat is None:
            raise ValueError("observations are flat only with flatten=True")
        return self._flat

    def state(self) -> np.ndarray:
        """Every world's global state, one row per world, as ``BatchedParallelEnv.state``."""
        with self._guard:
            if not self._ready:
                raise RuntimeError("call reset() before state()")
            for k in range(self.num_shards):
                self._send(k, ("state", None))
            return np.concatenate([self._answer(k) for k in range(self.num_shards)])

    def close(self) -> None:
        for pipe in self._pipes:
            try:
                pipe.send(("close", None))
            except (OSError, ValueError):
                pass
        for process in self._processes:
            process.join(timeout=5)
            if process.is_alive():
                process.terminate()
                process.join()
        for pipe in self._pipes:
            pipe.close()
        self._pipes, self._processes, self._ready = [], [], False

    def __del__(self):
        if getattr(self, "_processes", None):
            self.close()

    # -- inside -------------------------------------------------------------------------

    def _plainly_valid(self, actions) -> bool:
        """Whether ``actions`` is an integer array of the discrete space's values (checked
        at once; anything else is checked slot by slot)."""
        space = self.single_action_space
        if not (
            isinstance(space, gymnasium.spaces.Discrete)
            and isinstance(actions, np.ndarray)
            and actions.dtype.kind in "iu"
            and actions.shape == (self.num_slots,)
        ):
            return False
        acting = actions[self._acting]
        return bool(((acting >= space.start) & (acting < space.start + space.n)).all())

    def _check(self, actions) -> dict[int, Any]:
        """The action of every slot that acts next step, checked as the batched env checks
        it (the same errors); nothing is sent before all have passed."""
        m = self.agents_per_world
        checked = {}
        for slot in np.flatnonzero(self._acting):
            agent = self._checker.possible_agents[slot % m]
            try:
                checked[slot] = self._checker.actuators[slot % m].check(agent, actions[slot])
            except ValueError as err:
                raise ValueError(f"world {slot // m}, slot {slot}: {err}") from None
        return checked

    def _send(self, k: int, message) -> None:
        try:
            self._pipes[k].send(message)
        except (OSError, ValueError):
            raise RuntimeError(self._dead(k)) from None

    def _answer(self, k: int, timeout: float | None = None):
        pipe = self._pipes[k]
        if timeout is not None and not pipe.poll(timeout):
            raise RuntimeError(f"shard {k} did not answer within {timeout:.0f} s")
        try:
            status, payload = pipe.recv()
        except (EOFError, OSError):
            raise RuntimeError(self._dead(k)) from None
        if status == "error":
            raise RuntimeError(f"shard {k} failed: {payload}")
        return payload

    def _collect(self, shards: list[int] | None = None) -> None:
        self._finals = {}
        for k in range(self.num_shards) if shards is None else shards:
            objects, finals = self._answer(k)
            for key, values in objects.items():
                self._object_infos[key][self._slots[k]] = values
            first = self._slots[k].start
            self._finals.update({first + slot: final for slot, final in finals.items()})
        # The slots whose actions the next step uses, as each shard's batch says.
        self._acting = self._arrays["acting"].copy()

    def _dead(self, k: int) -> str:
        process = self._processes[k]
        process.join(timeout=1)
        return f"shard {k} ({process.name}) stopped (exit code {process.exitcode})"

    def _results(self):
        a = self._arrays
        if "obs" in a:
            observations = a["obs"]
        else:
            observations = {name[4:]: v for name, v in a.items() if name.startswith("obs/")}
        out = (observations, a["rewards"], a["terminations"], a["truncations"])
        if not self.copy:
            return out
        return tuple(
            {k: v.copy() for k, v in x.items()} if isinstance(x, dict) else x.copy() for x in out
        )

    def _infos(self) -> dict:
        a = self._arrays
        infos = {name[5:]: v for name, v in a.items() if name.startswith("info/")}
        infos.update(self._object_infos)
        infos["active"] = a["active"]
        if self.copy:
            infos = {key: values.copy() for key, values in infos.items()}
        return infos
