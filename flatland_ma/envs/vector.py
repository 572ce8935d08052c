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

The step is the core's (``flatland_ma.envs.worlds.Worlds``: every world's bodies driven,
poses read and rays cast at once, per-slot arrays); this env checks the batch of actions
(at once when it is one array in the space, else slot by slot), applies the autoreset
mode and hands the slots' arrays out.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from flatland_ma.envs.batched_steps import checked_at_once, checked_by_slot
from flatland_ma.envs.buffers import world_seeds
from flatland_ma.envs.checked_spec import checked_spec
from flatland_ma.envs.flatten import FlatLayout, FlatPart
from flatland_ma.envs.guards import OneCaller, check_batch_of_actions
from flatland_ma.envs.resets import autoreset_mode_of, final_infos, reset_mask_of
from flatland_ma.envs.slots import slot_spaces
from flatland_ma.envs.world_loop import WorldLoop
from flatland_ma.envs.worlds import Worlds
from flatland_ma.scenario.budget import check_batch

AUTORESET_MODE = AutoresetMode.NEXT_STEP
"""The batched envs' default autoreset mode (``flatland_ma.envs.resets``)."""
VECTOR_RENDER_MODES = ["rgb_array"]
"""What the envs of many worlds render: one frame per world (no window per world)."""


def slot_observation(observations, slot: int):
    """One slot's observation out of a batched env's observations (a dict of arrays, one
    entry per slot in each, or one array), as a policy of one agent reads it."""
    if isinstance(observations, dict):
        return {key: value[slot] for key, value in observations.items()}
    return observations[slot]


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
        first = WorldLoop(checked_spec(scenario, max_cycles, overrides), render_mode)
        check_batch(first.spec, num_worlds, _counted_as)  # before the other worlds are built
        self._guard = OneCaller("this batched env")
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
        self.flat = spaces.flat
        """How a slot's observation lies in its flat vector (``flatten=True``), or None."""
        self.single_observation_space = spaces.observation
        self.single_action_space = spaces.action
        self.single_state_space = first.state_space
        """One world's global state space (``FlatlandParallelEnv.state``)."""
        self.state_space = batch_space(first.state_space, num_worlds)
        self.observation_space = batch_space(self.single_observation_space, self.num_slots)
        self.action_space = batch_space(self.single_action_space, self.num_slots)
        self.core = Worlds(first, num_worlds, spaces, copy, parallel, render_mode is None)
        """The worlds and their slots' arrays (``flatland_ma.envs.worlds``)."""
        self.worlds = self.core.loops
        """Each world's loop (``flatland_ma.envs.world_loop``), in world order."""

    # -- the loop -----------------------------------------------------------------------

    def reset(self, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every world: world ``w`` with ``seed + w`` (or ``seed[w]``; None: from
        fresh entropy); with ``options={"reset_mask": mask}`` only the worlds whose entry
        of ``mask`` (one bool per world) is True (``flatland_ma.envs.resets``)."""
        with self._guard:
            mask = reset_mask_of(options, self.num_worlds)
            self.core.reset(world_seeds(seed, self.num_worlds), mask)
            return self.core.slots.observed(), self.core.slots.infos()

    def step(self, actions):
        """One step of every world; ``actions[slot]`` for each slot (those of inert slots
        and of worlds being reset are not used). Every action is checked before anything
        moves: a bad one raises an error naming its world, agent, value and space (and
        anything but one action per slot a ``TypeError`` or ``ValueError`` saying what a batch
        takes)."""
        with self._guard:
            checked, at_once = self._check(actions)
            same_step = self.autoreset_mode == AutoresetMode.SAME_STEP
            finals = self.core.step(checked, at_once, same_step)
            slots = self.core.slots
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
        return self.core.acting()

    @property
    def active(self) -> np.ndarray:
        """Which slots hold an agent still playing (``infos["active"]`` of the last step or
        reset); the env's own array, not a copy."""
        return self.core.slots.active

    def render(self) -> tuple | None:
        """With ``render_mode="rgb_array"``: every world's frame, in world order (a tuple,
        as Gymnasium's ``SyncVectorEnv`` gives); None without a render mode."""
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without a render_mode; nothing to draw")
            return None
        with self._guard:
            return tuple(loop.render() for loop in self.worlds)

    def flat_layout(self) -> tuple[FlatPart, ...]:
        """With ``flatten=True``: where each entry of a slot's observation lies in its flat
        vector (name, start, stop, shape)."""
        return self._flat_layout().parts

    def unflatten(self, vector) -> np.ndarray | dict[str, np.ndarray]:
        """With ``flatten=True``: one slot's flat observation as it is without flattening."""
        return self._flat_layout().unflatten(vector)

    def _flat_layout(self) -> FlatLayout:
        if self.flat is None:
            raise ValueError("observations are flat only with flatten=True")
        return self.flat

    def state(self) -> np.ndarray:
        """Every world's global state (``FlatlandParallelEnv.state``), one row per world,
        for centralised critics: slot ``s`` plays in world ``s // agents_per_world``. A
        world whose episode ended on the last step shows its final state until the next
        step resets it."""
        with self._guard:
            if not self.core.started():
                raise RuntimeError("call reset() before state()")
            return np.stack([loop.state() for loop in self.worlds])

    def close(self) -> None:
        for loop in self.worlds:
            loop.close()

    @property
    def layout(self) -> str:
        """Which slot is which, in words."""
        return f"{self.num_worlds} worlds x {self.agents_per_world} agents"

    # -- inside -------------------------------------------------------------------------

    def _check(self, actions) -> tuple[list, np.ndarray | None]:
        """Each live agent's action, checked, world by world, and ``actions`` itself
        when it was checked at once (one array in the space); nothing is changed."""
        if not self.core.started():
            raise RuntimeError("call reset() first")
        ended = self.core.ended
        if self.autoreset_mode == AutoresetMode.DISABLED and any(ended):
            over = [w for w, gone in enumerate(ended) if gone]
            raise RuntimeError(
                f"the episodes of worlds {over} are over and autoreset_mode is DISABLED: "
                'reset them first with reset(options={"reset_mask": mask})'
            )
        check_batch_of_actions(actions, self.num_slots, self.single_action_space, self.layout)
        m = self.agents_per_world
        fast = checked_at_once(actions, self.core.actuator, self.worlds, ended, m)
        if fast is None:
            return checked_by_slot(actions, self.worlds, ended, m), None
        return fast, actions
