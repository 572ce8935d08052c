"""The PettingZoo AEC environment, derived from the parallel one.

PettingZoo's ``parallel_to_aec_wrapper`` gives the turn-taking; the only addition is that
each agent's action is checked on its own turn, so a bad action fails at once, names its
agent, value and space, and leaves the round as it was (the agent can act again).
``aec_to_parallel`` still unwraps it to the parallel env.
"""

from __future__ import annotations

from pettingzoo import AECEnv
from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from flatland_ma.envs.parallel import FlatlandParallelEnv


class FlatlandAECEnv(parallel_to_aec_wrapper):
    """``parallel_to_aec_wrapper`` that checks the acting agent's action before storing it."""

    env: FlatlandParallelEnv

    def step(self, action) -> None:
        agent = self.agent_selection
        if not (self.terminations[agent] or self.truncations[agent]):
            self.env.check_action(agent, action)
        super().step(action)

    def action_names(self, agent: str | None = None) -> tuple[str, ...]:
        """What each discrete action or each continuous entry means, in order (of the
        first agent, unless ``agent`` says whose)."""
        return self.env.action_names(agent)

    def action_index(self, name: str, agent: str | None = None) -> int:
        """The discrete action (or continuous entry) called ``name``, e.g. ``"grasp"``."""
        return self.env.action_index(name, agent)

    def flat_layout(self, agent: str):
        """With ``flatten=True``: where each entry lies in the agent's flat observation."""
        return self.env.flat_layout(agent)

    def unflatten(self, agent: str, vector):
        """With ``flatten=True``: the agent's observation ``vector`` as the parts."""
        return self.env.unflatten(agent, vector)


def env(
    scenario="fruits_poisons",
    render_mode: str | None = None,
    max_cycles: int | None = None,
    flatten: bool = False,
    **overrides,
) -> AECEnv:
    """AEC view of ``FlatlandParallelEnv``: agents act in turn, physics runs once all have.
    ``max_cycles`` sets the episode length (the scenario's ``episode.max_steps``);
    ``flatten=True`` makes each observation one float32 vector (``flatland_ma.envs.flatten``).
    """
    parallel = FlatlandParallelEnv(
        scenario, render_mode=render_mode, max_cycles=max_cycles, flatten=flatten, **overrides
    )
    return OrderEnforcingWrapper(FlatlandAECEnv(parallel))
