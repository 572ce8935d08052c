"""The actor-critic network of the batched PPO, for whatever an agent observes and does.

Its layers are ``flatland_ma.policies.networks.PPONetwork``, the definition a checkpoint
is rebuilt from; ``Agent`` adds what training needs (sampling, log-probabilities, the
value), so training and playing share one network.

It reads the env's raw observations, exactly as the env gives them (a batch of arrays, or
of dicts of arrays for a ``Dict`` space), so the module a checkpoint holds needs no
preprocessing. Each entry of the observation is encoded by its shape:

- a first-person image, (rays, channels): 1-D convolutions over the rays, on its first
  ``channels`` channels (colour, plus depth when asked);
- a map, (height, width, channels): 2-D convolutions;
- anything else (the heard messages, proprioception, ...): flattened as it is.

The encodings are joined and pass one fully connected layer (``hidden`` units), shared by
the value head and the policy's heads. With ``state_size`` the value comes instead from a
critic of its own that reads the world's global state and which agent the slot is (a
centralised critic, as MAPPO's; Yu et al., "The Surprising Effectiveness of PPO in
Cooperative Multi-Agent Games", 2022): two layers of ``hidden`` units. The policy still
reads only the agent's own observation, so a checkpoint plays without the state.

A ``Discrete`` action space has one categorical head; a ``MultiDiscrete`` one (moves plus
words on the channel) has one per component, independent given the features: an action's
log-probability and entropy are the sums of its components'. The policy's logits come
out joined along the last axis.
"""

from __future__ import annotations

import torch
from gymnasium import spaces

from baselines.common import input_channels
from flatland_ma.policies.networks import (
    BOX,
    MAP,
    STRIDED,
    FlatInput,
    ImageInput,
    MapInput,
    PPONetwork,
    entry_input,
    layer_init,
    strided_trunk,
)

__all__ = [
    "MAP",
    "STRIDED",
    "Agent",
    "FlatInput",
    "ImageInput",
    "MapInput",
    "action_sizes",
    "entry_input",
    "layer_init",
    "observation_entries",
    "strided_trunk",
]


def observation_entries(space: spaces.Space) -> dict[str, tuple[int, ...]]:
    """The shape of each entry of an observation space: ``{BOX: shape}`` for a ``Box``."""
    if isinstance(space, spaces.Dict):
        entries = {key: sub.shape for key, sub in space.spaces.items()}
    else:
        entries = {BOX: space.shape}
    if any(shape is None for shape in entries.values()):
        raise ValueError(f"PPO reads Box entries, not {space}")
    return entries  # type: ignore[return-value]


def action_sizes(space: spaces.Space) -> tuple[int, ...]:
    """The number of choices of each component of a discrete action space."""
    if isinstance(space, spaces.Discrete):
        return (int(space.n),)
    if isinstance(space, spaces.MultiDiscrete) and space.nvec.ndim == 1:
        return tuple(int(n) for n in space.nvec)
    raise ValueError(f"PPO acts in Discrete or MultiDiscrete spaces, not {space}")


class Agent(PPONetwork):
    """``PPONetwork`` for these spaces, with PPO's sampling and value."""

    def __init__(
        self,
        observation_space: spaces.Space,
        action_space: spaces.Space,
        hidden: int = 128,
        channels: int = 3,
        network: str = "strided",
        state_size: int = 0,
        memory: str = "none",
        memory_size: int = 128,
        frames: int = 1,
        roles: int = 0,
    ):
        super().__init__(
            observation_entries(observation_space),
            action_sizes(action_space),
            hidden,
            channels,
            network,
            state_size,
            memory,
            memory_size,
            frames,
            roles,
        )

    def value(self, observation, state: torch.Tensor | None = None) -> torch.Tensor:
        """The value of each row: from ``state`` with a centralised critic, else from the
        observation."""
        if self.state_size:
            assert state is not None, "a centralised critic reads the state"
            return self.critic(state).squeeze(-1)
        return self.critic(self.features(observation)).squeeze(-1)

    def act(
        self,
        observation,
        action: torch.Tensor | None = None,
        state=None,
        generator: torch.Generator | None = None,
    ):
        """A sampled action (batch, heads) unless ``action`` is given (drawn from
        ``generator``, torch's global one if None), its log-probability, the policy's
        entropy and the value (from ``state`` with a centralised critic). Each head is a
        categorical over its logits, computed from the log-softmax directly (a third of
        ``torch.distributions.Categorical``'s cost at an acting batch)."""
        return self.decide(self.features(observation), action, state, generator)

    def decide(
        self,
        h: torch.Tensor,
        action: torch.Tensor | None = None,
        state=None,
        generator: torch.Generator | None = None,
    ):
        """``act`` from what the heads read: ``features``, or with memory what ``step`` or
        ``replay`` give."""
        heads = [logits.log_softmax(-1) for logits in self.actor(h).split(self.sizes, dim=-1)]
        if action is None:
            action = torch.cat(
                [torch.multinomial(head.exp(), 1, generator=generator) for head in heads], -1
            )
        logprob = heads[0].gather(-1, action[..., :1]).squeeze(-1)
        entropy = -(heads[0].exp() * heads[0]).sum(-1)
        for k, head in enumerate(heads[1:], 1):
            logprob = logprob + head.gather(-1, action[..., k : k + 1]).squeeze(-1)
            entropy = entropy - (head.exp() * head).sum(-1)
        if self.state_size:
            assert state is not None, "a centralised critic reads the state"
            return action, logprob, entropy, self.critic(state).squeeze(-1)
        return action, logprob, entropy, self.critic(h).squeeze(-1)


def network_options(args, env) -> dict:
    """``Agent``'s options besides the spaces for a ``baselines.ppo`` run's ``args`` on
    the batched ``env``; ``ValueError`` for ``--role-networks`` where the agents observe
    alike (one role)."""
    roles = 0
    if args.role_networks:
        roles = env.padding.roles if env.padding is not None else 1
        if roles < 2:
            raise ValueError(
                f"--role-networks: every agent of {args.scenario} observes alike (one role), "
                "so there is one network already"
            )
    return {
        "hidden": args.hidden,
        "channels": input_channels(args.use_depth),
        "network": args.network,
        "state_size": env.single_state_space.shape[0] + env.agents_per_world
        if args.critic == "state"
        else 0,
        "memory": args.memory,
        "memory_size": args.memory_size,
        "frames": args.frames,
        "roles": roles,
    }
