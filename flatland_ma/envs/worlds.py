"""The core of the envs of many worlds: K world loops of one scenario stepped at once, and
the per-slot arrays they write (every agent of every world is one slot: world ``w``'s
agent ``j`` is slot ``w * agents_per_world + j``).

``Worlds.step`` is array work over all worlds but for ``space.step``: every world's plain
bodies are driven in one compiled call (``agents.motors``; bodies with parts through each
world loop's ``act``), each world simulates and applies its rules (``WorldLoop.simulate``,
``conclude``), every world's moving bodies' poses are read back in one call, and the rays
of every world are cast in one call of the compiled kernel, spread over numba's threads
(``parallel=False``: on one), straight into the world's slots of the stacked observations
while they are its cameras' rays as they are and every agent plays (else into its own
image, then copied). Every world's rewards and terminations are written in one go while
every slot acts (else world by world), and each world's counters as slices of the stacked
arrays (only after a step that may have moved them: ``Task.revision``).

The slots' arrays (``slots``: observations, rewards, terminations, truncations, active,
counters) are the core's own; the adapters (``BatchedParallelEnv``, the Gymnasium vector
env, the shards, the stream's batched env) hand them out, copied or not. A world whose
last agent finished is ``ended``; ``step`` starts it again instead of stepping it (the
autoreset modes: ``flatland_ma.envs.resets``).
"""

from __future__ import annotations

import numpy as np

from flatland_ma.agents.motors import Motors
from flatland_ma.envs.batched_steps import drive, whole_image
from flatland_ma.envs.buffers import clear, put_column
from flatland_ma.envs.slots import SlotBuffers, SlotSpaces
from flatland_ma.envs.world_loop import WorldLoop
from flatland_ma.sensors.body_poses import Poses
from flatland_ma.sensors.sensor_suite import Sensors, WorldsKernel


class Worlds:
    """``num_worlds`` world loops like ``first`` (``first`` is the first of them) with the
    slots of ``spaces``; ``copy``: whether the slots' arrays are handed out copied;
    ``parallel``: whether the ray kernel may use numba's threads; ``direct``: whether the
    rays may be written straight into the slots (not with a render mode: then the sensors
    keep their readings)."""

    def __init__(
        self,
        first: WorldLoop,
        num_worlds: int,
        spaces: SlotSpaces,
        copy: bool,
        parallel: bool,
        direct: bool,
    ):
        self.loops = [first] + [_like(first) for _ in range(num_worlds - 1)]
        """Each world's loop, in world order."""
        self.num_worlds = num_worlds
        self.agents_per_world = m = len(first.possible_agents)
        self.num_slots = num_worlds * m
        self.padding = spaces.padding
        self.slots = SlotBuffers(spaces, self.num_slots, copy)
        """The stacked arrays of every slot."""
        self.ended = [False] * num_worlds
        """Worlds whose episode ended on the last step: the next step resets them."""
        self._revisions = [-1] * num_worlds
        """Each world's ``Task.revision`` when its counters were last written: a step that
        left it where it was changed none of them."""
        self.actuator = first.actuators[0]
        """The slots' actuator (every slot acts alike)."""
        plain = all(a.n_controls == 0 for a in first.actuators)
        self.motors = Motors(self.num_slots) if plain and Motors.available() else None
        """Every plain agent's motor, driven at once (None: bodies with parts)."""
        self.poses = Poses(num_worlds)
        """Every world's moving bodies' poses, read at once for the rays."""
        self.whole_image = self.padding is None and direct
        """Whether a world's observations are its cameras' rays as they are, agent after
        agent (see ``batched_steps.whole_image``)."""
        self._written = [False] * num_worlds
        """Worlds whose rays the kernel writes straight into their slots of the stacked
        observations (``whole_image``, while every agent of the world plays); the others
        write their own image, copied by ``_observe``."""
        self.kernel = WorldsKernel(num_worlds, parallel)
        """Every world's ray kernel arguments: one call casts the rays of all."""

    # -- starting episodes --------------------------------------------------------------

    def reset(self, seeds: list[int | None], mask: np.ndarray | None) -> None:
        """Start a new episode in every world (``mask``: those whose entry is True), world
        ``w`` seeded with ``seeds[w]``; their slots' rewards and flags are cleared."""
        m, slots = self.agents_per_world, self.slots
        for w in range(self.num_worlds):
            if mask is None or mask[w]:
                rows = slice(w * m, (w + 1) * m)
                slots.rewards[rows] = 0.0
                slots.terminations[rows] = False
                slots.truncations[rows] = False
                self.restart(w, seeds[w])

    def restart(self, w: int, seed: int | None = None) -> None:
        """Start world ``w``'s next episode (seeded with ``seed``; None: its generator
        continues) and put its first observations and counters into its slots."""
        loop, m = self.loops[w], self.agents_per_world
        loop.enter()
        try:
            loop.start(seed)
            observations = [loop.observe(j) for j in range(m)]
            task = loop.running.task
            infos = [task.info(j) for j in range(m)]
        finally:
            loop.leave()
        self._place(w, loop)
        base, slots = w * m, self.slots
        for j in range(m):
            if self.padding is not None:  # inert slots were zeroed: name the role again
                self.padding.mark(slots.observations, j, base + j)
            slots.put(base + j, j, observations[j])
            slots.active[base + j] = True
            slots.count(base + j, infos[j])
        self._revisions[w] = task.revision
        self.ended[w] = False

    def _place(self, w: int, loop: WorldLoop) -> None:
        """Point the kernel, the poses and the motors at world ``w``'s new episode."""
        episode, base = loop.running, w * self.agents_per_world
        if w == 0:
            self.whole_image = self.whole_image and whole_image(episode.sensors)
        self._written[w] = self.whole_image
        if self.whole_image:  # the rays write straight into the world's slots
            rows = self.slots.observations[base : base + self.agents_per_world]
            self.kernel.set(w, episode.sensors, rows.reshape(-1, rows.shape[-1]))
        else:
            self.kernel.set(w, episode.sensors)
        geometry = episode.sensors.geometry
        self.poses.place(w, geometry.pose, geometry.bodies)
        if self.motors is not None:
            for j, body in enumerate(episode.bodies):
                if not Motors.fits(body):
                    self.motors = None  # a body with parts: each agent's own act
                    break
                self.motors.place(base + j, body)

    # -- the step -----------------------------------------------------------------------

    def step(self, checked: list, at_once: np.ndarray | None, same_step: bool) -> dict:
        """One step of every world: ``checked`` holds each world's live agents' checked
        actions (none for an ended world, which starts again instead), ``at_once`` the
        batch's array when it was checked at once. With ``same_step``, worlds that end
        start again in this step. Returns the slots that finished with ``same_step``:
        slot -> (last observation, counters)."""
        slots = self.slots
        slots.rewards[:] = 0.0
        slots.terminations[:] = False
        slots.truncations[:] = False
        stepped: list[tuple[int, WorldLoop]] = []
        outcomes: list = []
        finals: dict = {}
        try:
            every_slot = self._begin(stepped) and at_once is not None
            outcomes = self._advance(stepped, checked, at_once if every_slot else None)
            finals = self._write(outcomes, every_slot, same_step)
        finally:
            for _, loop in stepped:
                loop.leave()
        if finals:  # SAME_STEP: the worlds that ended start again now
            for w, *_ in outcomes:
                if self.ended[w]:
                    self.restart(w)
        return finals

    def _begin(self, stepped: list) -> bool:
        """Start the ended worlds again, make the slots of agents gone inert, and claim
        the worlds to step (appended to ``stepped``); whether every slot acts."""
        every_slot = True
        for w, loop in enumerate(self.loops):
            if self.ended[w]:  # NEXT_STEP: reset instead (DISABLED: refused before)
                self.restart(w)
                every_slot = False
                continue
            if len(loop.live) < self.agents_per_world:
                every_slot = False
                self._inert(w, loop)
            loop.enter()
            stepped.append((w, loop))
        return every_slot

    def _inert(self, w: int, loop: WorldLoop) -> None:
        """Agents gone before this step are inert from now: their slots are zeroed."""
        slots, base = self.slots, w * self.agents_per_world
        if self._written[w]:  # the rays go to the world's own image again
            self.kernel.set(w, loop.running.sensors)
            self._written[w] = False
        for j in range(self.agents_per_world):
            if slots.active[base + j] and j not in loop.live:
                slots.active[base + j] = False
                clear(slots.observations, base + j)

    def _advance(self, stepped: list, checked: list, whole: np.ndarray | None) -> list:
        """Drive every world's bodies, simulate world by world, then read every world's
        poses and cast every world's rays in one call each."""
        motors = self.motors
        if motors is not None:
            drive(motors, self.actuator, stepped, checked, whole)
        outcomes = []
        for w, loop in stepped:
            if motors is None:
                loop.act(checked[w])
            else:
                loop.drove(checked[w])
            rewards, terminated = loop.simulate()
            loop.running.sensors.prepare(poses=False)
            outcomes.append((w, loop, *loop.conclude(rewards, terminated)))
        if outcomes:
            which = np.array([outcome[0] for outcome in outcomes], np.int64)
            self.poses.read(which)
            self.kernel.observe(which)
        return outcomes

    def _write(self, outcomes: list, every_slot: bool, same_step: bool) -> dict:
        """Each stepped world's observations, rewards, ends and counters into its slots;
        the finals of ``same_step``."""
        m, slots = self.agents_per_world, self.slots
        finals: dict[int, tuple] = {}
        # While every slot acts, rewards and terminations go in once after the loop (a
        # numpy write per world costs more than the world's rules).
        all_rewards: list[float] = []
        all_terminated: list[bool] = []
        for w, loop, live, rewards, terminated, truncated in outcomes:
            base = w * m
            whole = len(live) == m  # the world's live slots: a slice while all play
            rows = slice(base, base + m) if whole else [base + i for i in live]
            if not (whole and self._written[w]):
                self._observe(loop.running.sensors, base, live, rows)
            if every_slot:
                all_rewards += rewards
                all_terminated += terminated
            else:
                slots.rewards[rows] = [rewards[i] for i in live]
                slots.terminations[rows] = [terminated[i] for i in live]
            if truncated:
                slots.truncations[rows] = True
            task = loop.running.task
            if task.revision != self._revisions[w]:  # the counters may have moved
                self._revisions[w] = task.revision
                for key, values in task.columns(live).items():
                    put_column(slots.counter(key, values[0]), rows, base, live, values)
            if same_step:
                for i in live:
                    if terminated[i] or truncated:
                        finals[base + i] = (slots.seen(base + i), task.info(i))
            self.ended[w] = not loop.agents
        if every_slot:
            slots.rewards[:] = all_rewards
            slots.terminations[:] = all_terminated
        return finals

    def _observe(self, sensors: Sensors, base: int, live: list[int], rows) -> None:
        """Put the observations of a world's ``live`` agents (in slots ``rows``, its
        agents from slot ``base``) into the stacked buffer: while it is the concatenation
        of the cameras' rays (``whole_image``), in one copy, else agent by agent."""
        if self.whole_image:
            image = sensors.image.reshape(self.agents_per_world, -1, sensors.image.shape[1])
            self.slots.observations[rows] = image if len(live) == len(image) else image[live]
            return
        for i in live:
            self.slots.put(base + i, i, sensors.observation(i))

    # -- reading ------------------------------------------------------------------------

    def started(self) -> bool:
        """Whether every world has an episode (after the first reset)."""
        return all(loop.episode is not None for loop in self.loops)

    def acting(self) -> np.ndarray:
        """Which slots' actions the next step uses: live agents of worlds it steps (not
        inert slots, not worlds it resets instead)."""
        m = self.agents_per_world
        out = np.zeros(self.num_slots, bool)
        for w, loop in enumerate(self.loops):
            if not self.ended[w] and loop.episode is not None:
                out[[w * m + i for i in loop.live]] = True
        return out


def _like(first: WorldLoop) -> WorldLoop:
    """Another world loop of ``first``'s checked spec, its step limit and render mode."""
    loop = WorldLoop(first.spec, first.render_mode, first.flatten)
    loop.step_limit = first.step_limit
    return loop
