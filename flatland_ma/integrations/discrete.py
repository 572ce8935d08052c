"""One ``Discrete`` action for agents that act through ``MultiDiscrete`` (a move and words
on a channel), for clients that take only ``Discrete`` or ``Box`` (Tianshou's DQN,
BenchMARL, AgileRL's MADDPG)::

    from flatland_ma.integrations.discrete import DiscreteActions, discrete_aec_env

    env = DiscreteActions(flatland_ma.parallel_env("signal_rooms"))
    env.action_space("seeker_0")         # Discrete(6): 3 moves x 2 words
    env.decode("seeker_0", 5)            # array([2, 1]): rotate right, say word 1
    env.encode("seeker_0", [2, 1])       # 5
    aec = discrete_aec_env("signal_rooms")   # the same, turn by turn (PettingZoo AEC)

The code: a ``MultiDiscrete(nvec)`` action ``(move, word_0, ..., word_{k-1})`` is the
number ``numpy.ravel_multi_index(action, nvec)``: the move is the most significant
digit, the last word the least (``index = move * V**k + word_0 * V**(k-1) + ...`` for a
vocabulary of ``V`` words). Agents whose action space is ``Discrete`` or ``Box`` keep it.

A bad action (not an integer, or out of range) raises ``ValueError`` naming the agent,
the value and the space, before anything moves. Actions for agents that have finished are
passed on as they are, so the env ignores them.
"""

from __future__ import annotations

from numbers import Integral

import numpy as np
from gymnasium import spaces
from pettingzoo.utils.wrappers import BaseParallelWrapper


class ActionCode:
    """The ``Discrete`` numbering of one ``MultiDiscrete`` space (the module's docstring)."""

    def __init__(self, space: spaces.MultiDiscrete):
        if space.nvec.ndim != 1 or np.any(space.start != 0):
            raise ValueError(
                f"a one-dimensional MultiDiscrete starting at 0 is needed, not {space}"
            )
        self.original = space
        self.nvec = tuple(int(n) for n in space.nvec)
        self.space = spaces.Discrete(int(np.prod(self.nvec, dtype=np.int64)))

    def decode(self, index) -> np.ndarray:
        """The ``MultiDiscrete`` action numbered ``index``."""
        digits = np.unravel_index(int(index), self.nvec)
        return np.array(digits, dtype=self.original.dtype)

    def encode(self, action) -> int:
        """The number of the ``MultiDiscrete`` action ``action``."""
        return int(np.ravel_multi_index(tuple(int(a) for a in action), self.nvec))


class DiscreteActions(BaseParallelWrapper):
    """A parallel env whose ``MultiDiscrete`` actions are each one ``Discrete`` action (the
    module's docstring); ``decode`` and ``encode`` translate between them."""

    def __init__(self, env):
        super().__init__(env)
        self._codes = {
            a: ActionCode(space)
            for a in env.possible_agents
            if isinstance(space := env.action_space(a), spaces.MultiDiscrete)
        }
        self.action_spaces = {
            a: self._codes[a].space if a in self._codes else env.action_space(a)
            for a in env.possible_agents
        }

    def action_space(self, agent):
        return self.action_spaces[agent]

    def decode(self, agent: str, index) -> np.ndarray:
        """Agent ``agent``'s action ``index`` as the wrapped env takes it."""
        code = self._codes[agent]
        if isinstance(index, np.ndarray) and index.shape == ():
            index = index.item()
        if (
            isinstance(index, bool)
            or not isinstance(index, (Integral, np.integer))
            or not 0 <= int(index) < code.space.n
        ):
            raise ValueError(
                f"action {index!r} for {agent!r} is not an element of {code.space} "
                f"(it numbers {code.original})"
            )
        return code.decode(index)

    def encode(self, agent: str, action) -> int:
        """The number of agent ``agent``'s action ``action`` of the wrapped env."""
        return self._codes[agent].encode(action)

    def step(self, actions):
        live = set(self.env.agents)
        decoded = {
            a: self.decode(a, action) if a in self._codes and a in live else action
            for a, action in actions.items()
        }
        return self.env.step(decoded)


def discrete_aec_env(scenario="signal_rooms", **kwargs):
    """``flatland_ma.env`` (PettingZoo AEC) with ``DiscreteActions``: keyword arguments are
    ``flatland_ma.parallel_env``'s."""
    from pettingzoo.utils.conversions import parallel_to_aec

    from flatland_ma.envs.parallel import FlatlandParallelEnv

    return parallel_to_aec(DiscreteActions(FlatlandParallelEnv(scenario, **kwargs)))
