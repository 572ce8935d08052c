"""Many worlds of one scenario in one process, stepped together.

``BatchedParallelEnv`` presents every agent of every world as one slot, for learners that
share one policy's parameters among agents: world ``w``'s agent ``j`` is slot
``w * agents_per_world + j``. Observations come stacked along a leading slot axis (a
``Dict`` observation as a dict of stacked arrays), and rewards, terminations and
truncations as arrays of one entry per slot.

Worlds reset as Gymnasium 1.x's ``autoreset_mode`` says (``flatland_ma.envs.resets``):
by default ``NEXT_STEP``, where the step after the one in which a world's last agent
finished resets that world (its actions are not used) and returns the first observation of
its new episode, with reward 0 and neither termination nor truncation; ``SAME_STEP`` resets
it in that step and puts the final observations in ``infos["final_obs"]``; ``DISABLED``
leaves it to ``reset(options={"reset_mask": mask})``. A world reset automatically continues
its own generator, so world ``w`` of a batch reset with seed ``s`` plays exactly the
episodes of a ``FlatlandParallelEnv`` reset with seed ``s + w`` and then reset without a
seed each time its episode ends.

``flatten=True`` gives every slot one float32 vector, laid out as the single env's
``flatten=True`` lays it (``flatland_ma.envs.flatten``; ``flat_layout`` and ``unflatten``).
``render_mode="rgb_array"`` makes ``render()`` return a tuple of frames, one per world,
as Gymnasium's ``SyncVectorEnv`` does.

Agents that finish while their world plays on leave it (as in the parallel env): from the
next step their slot is inert, ``infos["active"]`` is False for it, its observation is
zeros, its reward 0, and its action is not used; a learner drops those entries.

Its size is held to the work budget before anything is allocated
(``flatland_ma.scenario.budget.check_batch``: ``num_worlds`` times what a world of the
scenario takes, sensors included), and one thread at a time may call it (a second thread
calling in meanwhile gets a ``RuntimeError``; ``flatland_ma.envs.guards``).

The arrays returned are copies, unless ``copy=False``: then they are the env's own buffers,
overwritten by the next ``step`` or ``reset``.

A step is array work over all worlds but for ``space.step`` (``batched_steps``): the batch
of actions is checked at once, every world's plain bodies are driven in one compiled call
(``agents.motors``), each world simulates and applies its rules, every world's moving
bodies' poses are read back in one call, the rays of every world are cast in one call of
the compiled kernel, spread over numba's threads (``parallel=False``: on one), straight
into the world's slots of the stacked observations while they are its cameras' rays as
they are and every agent plays (else into its own image, then copied), every world's
rewards and terminations are written in one go while every slot acts (else world by
world), and each world's counters as slices of the stacked arrays (only after a step that
may have moved them: ``Task.revision``).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from flatland_ma.agents.motors import Motors, Poses
from flatland_ma.envs.batched_steps import checked_at_once, checked_by_slot, drive, whole_image
from flatland_ma.envs.buffers import clear, put_column, world_seeds
from flatland_ma.envs.flatten import FlatLayout, FlatPart
from flatland_ma.envs.guards import OneCaller, check_batch_of_actions
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.envs.resets import autoreset_mode_of, final_infos, reset_mask_of
from flatland_ma.envs.slots import SlotBuffers, slot_spaces
from flatland_ma.scenario.budget import check_batch
from flatland_ma.sensors.sensor_suite import Sensors, WorldsKernel

AUTORESET_MODE = AutoresetMode.NEXT_STEP
"""The batched envs' default autoreset mode (``flatland_ma.envs.resets``)."""
VECTOR_RENDER_MODES = ["rgb_array"]
"""What the envs of many worlds render: one frame per world (no window per world)."""


def check_vector_render_mode(render_mode: str | None) -> None:
    if render_mode is not None and render_mode not in VECTOR_RENDER_MODES:
        raise ValueError(
            f"render_mode {render_mode!r}: the envs of many worlds render {VECTOR_RENDER_MODES} "
            "(a tuple of frames, one per world)"
        )


class BatchedParallelEnv:
    """``num_worlds`` worlds of ``scenario`` (with ``overrides`` and ``max_cycles`` as
    for ``FlatlandParallelEnv``), every agent of every world one slot (see the module's
    docstring). Every agent must have the same spaces (one shared policy), unless ``pad``:
    then agents that observe differently (but act alike) are given one padded observation
    space with their role in it (``flatland_ma.envs.padding``); ``padding`` is None when
    nothing needed padding. ``flatten``, ``autoreset_mode`` and ``render_mode``: see the
    module's docstring. ``num_worlds`` worlds must fit the work budget
    (``flatland_ma.scenario.budget.check_batch``); ``_counted_as`` is the name the refusal
    gives them (``num_envs`` for ``gymnasium.make_vec``)."""

    metadata = {"autoreset_mode": AUTORESET_MODE, "render_modes": VECTOR_RENDER_MODES}

    def __init__(
        self,
        scenario: Any = "fruits_poisons",
        num_worlds: int = 1,
        max_cycles: int | None = None,
        copy: bool = True,
        parallel: bool = True,
        pad: bool = False,
        flatten: bool = False,
        autoreset_mode: AutoresetMode | str = AUTORESET_MODE,
        render_mode: str | None = None,
        *,
        _counted_as: str = "num_worlds",
        **overrides,
    ):
        if isinstance(num_worlds, bool) or not isinstance(num_worlds, int) or num_worlds < 1:
            raise ValueError(f"{_counted_as} must be a positive integer, not {num_worlds!r}")
        if not isinstance(flatten, bool):
            raise TypeError(f"flatten must be True or False, not {flatten!r}")
        self.autoreset_mode = autoreset_mode_of(autoreset_mode)
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        check_vector_render_mode(render_mode)
        self.render_mode = render_mode
        first = FlatlandParallelEnv(
            scenario, max_cycles=max_cycles, render_mode=render_mode, **overrides
        )
        check_batch(first.spec, num_worlds, _counted_as)  # before the other worlds are built
        self._guard = OneCaller("this batched env")
        self.worlds = [first] + [_same(first) for _ in range(num_worlds - 1)]
        self.spec = first.spec
        self.num_worlds = num_worlds
        self.possible_agents = list(first.possible_agents)
        """The agents of each world, in slot order."""
        self.agents_per_world = len(first.possible_agents)
        self.num_slots = num_worlds * self.agents_per_world
        self.copy = copy  # as given (the slots' arrays are handed out copied or not)
        spaces = slot_spaces(first, pad, flatten)
        self.padding = spaces.padding
        """How observations are padded to one space, or None (see ``pad``)."""
        self._flat = spaces.flat
        self.single_observation_space = spaces.observation
        self.single_action_space = spaces.action
        self.single_state_space = first.state_space
        """One world's global state space (``FlatlandParallelEnv.state``)."""
        self.state_space = batch_space(first.state_space, num_worlds)
        self.observation_space = batch_space(self.single_observation_space, self.num_slots)
        self.action_space = batch_space(self.single_action_space, self.num_slots)
        self._slots = SlotBuffers(spaces, self.num_slots, copy)
        """The stacked arrays handed out, one row per slot."""
        self._ended = [False] * num_worlds
        """Worlds whose episode ended on the last step: the next step resets them."""
        self._revisions = [-1] * num_worlds
        """Each world's ``Task.revision`` when its counters were last written: a step that
        left it where it was changed none of them."""
        self._actuator = first._actuators[0]
        self._motors = (
            Motors(self.num_slots)
            if all(a.n_controls == 0 for a in first._actuators) and Motors.available()
            else None
        )
        """Every plain agent's motor, driven at once (None: bodies with parts)."""
        self._poses = Poses(num_worlds) if Poses.fits() else None
        """Every world's moving bodies' poses, read at once for the rays."""
        self._whole_image = self.padding is None and render_mode is None
        """Whether a world's observations are its cameras' rays as they are, agent after
        agent (see ``whole_image``; with a render mode, sensors keep their readings)."""
        self._written = [False] * num_worlds
        """Worlds whose rays the kernel writes straight into their slots of the stacked
        observations (``_whole_image``, while every agent of the world plays); the others
        write their own image, copied by ``_observe``."""
        self._rays = WorldsKernel(num_worlds, parallel)
        """Every world's ray kernel arguments: one call casts the rays of all, over every
        core numba may use unless ``parallel`` is False."""

    # -- the loop -----------------------------------------------------------------------

    def reset(self, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every world: world ``w`` with ``seed + w`` (or ``seed[w]``; None: from
        fresh entropy); with ``options={"reset_mask": mask}`` only the worlds whose entry
        of ``mask`` (one bool per world) is True (``flatland_ma.envs.resets``)."""
        with self._guard:
            return self._reset(seed, reset_mask_of(options, self.num_worlds))

    def _reset(self, seed, mask: np.ndarray | None = None):
        seeds = world_seeds(seed, self.num_worlds)
        m = self.agents_per_world
        for w, env in enumerate(self.worlds):
            if mask is None or mask[w]:
                self._slots.rewards[w * m : (w + 1) * m] = 0.0
                self._slots.terminations[w * m : (w + 1) * m] = False
                self._slots.truncations[w * m : (w + 1) * m] = False
                self._restart(w, env, seeds[w])
        return self._slots.observed(), self._slots.infos()

    def step(self, actions):
        """One step of every world; ``actions[slot]`` for each slot (those of inert slots
        and of worlds being reset are not used). Every action is checked before anything
        moves: a bad one raises an error naming its world, agent, value and space (and
        anything but one action per slot a ``TypeError`` or ``ValueError`` saying what a batch
        takes)."""
        with self._guard:
            return self._step(actions)

    def _step(self, actions):
        checked, at_once = self._check(actions)
        m, slots = self.agents_per_world, self._slots
        slots.rewards[:] = 0.0
        slots.terminations[:] = False
        slots.truncations[:] = False
        advanced, entered, stepped = [], [], []
        finals: dict[int, tuple] = {}
        every_slot = at_once is not None  # acts, from the batch's array
        try:
            for w, env in enumerate(self.worlds):
                if self._ended[w]:  # NEXT_STEP: reset instead (DISABLED: refused in _check)
                    self._restart(w, env, None)
                    every_slot = False
                    continue
                base = w * m
                if len(env._live) < m:  # agents gone before this step are inert from now
                    every_slot = False
                    if self._written[w]:  # the rays go to the world's own image again
                        self._rays.set(w, env.running.sensors)
                        self._written[w] = False
                    for j in range(m):
                        if slots.active[base + j] and j not in env._live:
                            slots.active[base + j] = False
                            clear(slots.observations, base + j)
                env.enter()
                entered.append(env)
                stepped.append((w, env))
            # Drive every world's bodies at once, simulate world by world, then cast every
            # stepped world's rays in one call.
            motors = self._motors
            acted = motors is not None
            if motors is not None:
                drive(motors, self._actuator, stepped, checked, at_once if every_slot else None)
            poses = self._poses is None
            for w, env in stepped:
                advanced.append((w, env, *env._advance(checked[w], False, acted, poses)))
            if advanced:
                which = np.array([a[0] for a in advanced], np.int64)
                if self._poses is not None:
                    self._poses.read(which)
                self._rays.observe(which)
            same_step = self.autoreset_mode == AutoresetMode.SAME_STEP
            # While every slot acts, rewards and terminations go in once after the loop (a
            # numpy write per world costs more than the world's rules).
            all_rewards, all_terminated = [], []
            for w, env, live, rewards, terminated, truncated in advanced:
                episode, base = env.running, w * m
                # The world's live slots: a slice while every agent plays.
                whole = len(live) == m
                rows = slice(base, base + m) if whole else [base + i for i in live]
                if not (whole and self._written[w]):
                    self._observe(episode.sensors, base, live, rows)
                if every_slot:
                    all_rewards += rewards
                    all_terminated += terminated
                else:
                    slots.rewards[rows] = [rewards[i] for i in live]
                    slots.terminations[rows] = [terminated[i] for i in live]
                if truncated:
                    slots.truncations[rows] = True
                task = episode.task
                if task.revision != self._revisions[w]:  # the counters may have moved
                    self._revisions[w] = task.revision
                    for key, values in task.columns(live).items():
                        put_column(slots.counter(key, values[0]), rows, base, live, values)
                if same_step:
                    for i in live:
                        if terminated[i] or truncated:
                            finals[base + i] = (slots.seen(base + i), task.info(i))
                self._ended[w] = not env.agents
            if every_slot:
                slots.rewards[:] = all_rewards
                slots.terminations[:] = all_terminated
        finally:
            for env in entered:
                env.leave()
        if finals:  # SAME_STEP: the worlds that ended start again now
            for w, env, *_ in advanced:
                if self._ended[w]:
                    self._restart(w, env, None)
        infos = slots.infos()
        infos.update(final_infos(finals, slots.counters, self.num_slots))
        return (
            slots.observed(),
            slots.out(slots.rewards),
            slots.out(slots.terminations),
            slots.out(slots.truncations),
            infos,
        )

    def acting(self) -> np.ndarray:
        """Which slots' actions the next step uses: live agents of worlds it steps (not
        inert slots, not worlds it resets instead, not worlds over in ``DISABLED``)."""
        m = self.agents_per_world
        out = np.zeros(self.num_slots, bool)
        for w, env in enumerate(self.worlds):
            if not self._ended[w] and env.episode is not None:
                out[[w * m + i for i in env._live]] = True
        return out

    @property
    def active(self) -> np.ndarray:
        """Which slots hold an agent still playing (``infos["active"]`` of the last step or
        reset); the env's own array, not a copy."""
        return self._slots.active

    def render(self) -> tuple | None:
        """With ``render_mode="rgb_array"``: every world's frame, in world order (a tuple,
        as Gymnasium's ``SyncVectorEnv`` gives); None without a render mode."""
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without a render_mode; nothing to draw")
            return None
        with self._guard:
            return tuple(env.render() for env in self.worlds)

    def flat_layout(self) -> tuple[FlatPart, ...]:
        """With ``flatten=True``: where each entry of a slot's observation lies in its flat
        vector (name, start, stop, shape)."""
        return self._flat_layout().parts

    def unflatten(self, vector) -> np.ndarray | dict[str, np.ndarray]:
        """With ``flatten=True``: one slot's flat observation as it is without flattening."""
        return self._flat_layout().unflatten(vector)

    def _flat_layout(self) -> FlatLayout:
        if self._flat is None:
            raise ValueError("observations are flat only with flatten=True")
        return self._flat

    def state(self) -> np.ndarray:
        """Every world's global state (``FlatlandParallelEnv.state``), one row per world,
        for centralised critics: slot ``s`` plays in world ``s // agents_per_world``. A
        world whose episode ended on the last step shows its final state until the next
        step resets it."""
        with self._guard:
            if any(env.episode is None for env in self.worlds):
                raise RuntimeError("call reset() before state()")
            return np.stack([env.state() for env in self.worlds])

    def close(self) -> None:
        for env in self.worlds:
            env.close()

    @property
    def layout(self) -> str:
        """Which slot is which, in words."""
        return f"{self.num_worlds} worlds x {self.agents_per_world} agents"

    # -- inside -------------------------------------------------------------------------

    def _restart(self, w: int, env: FlatlandParallelEnv, seed: int | None) -> None:
        observations, infos = env.reset(seed=seed)
        base = w * self.agents_per_world
        if w == 0:
            self._whole_image = self._whole_image and whole_image(env.running.sensors)
        self._written[w] = self._whole_image
        if self._whole_image:  # the rays write straight into the world's slots
            slots = self._slots.observations[base : base + self.agents_per_world]
            self._rays.set(w, env.running.sensors, slots.reshape(-1, slots.shape[-1]))
        else:
            self._rays.set(w, env.running.sensors)
        if self._poses is not None:
            geometry = env.running.sensors.geometry
            self._poses.place(w, geometry.pose, geometry.bodies)
        if self._motors is not None:
            for j, body in enumerate(env.running.bodies):
                if not Motors.fits(body):
                    self._motors = None  # a body with parts: each agent's own apply
                    break
                self._motors.place(base + j, body)
        for j, agent in enumerate(env.possible_agents):
            if self.padding is not None:  # inert slots were zeroed: name the role again
                self.padding.mark(self._slots.observations, j, base + j)
            self._slots.put(base + j, j, observations[agent])
            self._slots.active[base + j] = True
            self._slots.count(base + j, infos[agent])
        self._revisions[w] = env.running.task.revision
        self._ended[w] = False

    def _observe(self, sensors: Sensors, base: int, live: list[int], rows) -> None:
        """Put the observations of a world's ``live`` agents (in slots ``rows``, its
        agents from slot ``base``) into the stacked buffer: while it is the concatenation
        of the cameras' rays (``_whole_image``), in one copy, else agent by agent."""
        if self._whole_image:
            image = sensors.image.reshape(self.agents_per_world, -1, sensors.image.shape[1])
            self._slots.observations[rows] = image if len(live) == len(image) else image[live]
            return
        for i in live:
            self._slots.put(base + i, i, sensors.observation(i))

    def _check(self, actions) -> tuple[list[list], np.ndarray | None]:
        """Each live agent's action, checked, world by world, and ``actions`` itself
        when it was checked at once (one array in the space); nothing is changed."""
        if any(env.episode is None for env in self.worlds):
            raise RuntimeError("call reset() first")
        if self.autoreset_mode == AutoresetMode.DISABLED and any(self._ended):
            over = [w for w, ended in enumerate(self._ended) if ended]
            raise RuntimeError(
                f"the episodes of worlds {over} are over and autoreset_mode is DISABLED: "
                'reset them first with reset(options={"reset_mask": mask})'
            )
        check_batch_of_actions(actions, self.num_slots, self.single_action_space, self.layout)
        m = self.agents_per_world
        fast = checked_at_once(actions, self._actuator, self.worlds, self._ended, m)
        if fast is None:
            return checked_by_slot(actions, self.worlds, self._ended, m), None
        return fast, actions


def _same(first: FlatlandParallelEnv) -> FlatlandParallelEnv:
    """Another env of ``first``'s checked spec, without loading and checking it again."""
    env = FlatlandParallelEnv.__new__(FlatlandParallelEnv)
    env._setup(first.spec, first.render_mode, first.flatten)
    env.step_limit = first.step_limit
    return env
