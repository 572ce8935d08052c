"""The networks a checkpoint can hold, one definition for training and for play.

A checkpoint names its network by ``kind`` with its constructor arguments (plain JSON)
and the spaces it reads and acts in; ``build_network`` rebuilds it from this code, never
from the file. The baselines train these same classes (``baselines.networks.Agent`` adds
PPO's sampling and value to ``PPONetwork``; ``baselines.a3c`` trains ``ActorCritic``).

- ``ppo``, ``PPONetwork``: each observation entry encoded by its shape - a first-person
  image, (rays, channels), by 1-D convolutions on its first ``channels`` channels; a map,
  (height, width, channels), by 2-D convolutions; anything else (the heard messages,
  proprioception, ...) flattened. The encodings are joined and pass one fully connected
  layer (``hidden`` units), then one linear head whose logits hold every action
  component's, joined. With ``state_size`` the value comes from a critic of its own on the
  world's global state (MAPPO's centralised critic), which play never reads. With
  ``frames: K`` each entry is read as its last K observations (joined along its channels,
  as the Nature DQN's frame stack); with ``memory: "gru"`` a one-layer GRU of ``memory_size``
  units follows the fully connected layer, and the heads read its state
  (``policies.memory`` keeps both between steps). With ``roles: R`` (a padded observation
  of R roles) each role has encoders and a fully connected layer of its own, and a row's
  action and value depend on its own role's alone (``policies.roles``).
- ``a3c``, ``ActorCritic``: the paper's A3C network, Conv1D(32, 8) - Conv1D(48, 4) -
  Conv1D(64, 3) - Dense(hidden), ELU, then the policy's logits and the value.

Every network maps a batch of raw observations, exactly as the env gives them (an array,
or a dict of arrays for a ``Dict`` space), to logits with ``logits``. Their layers per
observation entry, trunks and initialisations are in ``policies.encoders``. This module
imports torch; ``flatland_ma`` imports it only when a checkpoint is used.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import torch
from torch import nn

from flatland_ma.envs.padding import ROLE
from flatland_ma.policies.encoders import (
    CONV_CHANNELS,
    CONV_KERNELS,
    MAP,
    STRIDED,
    FlatInput,
    ImageInput,
    MapInput,
    conv_trunk,
    entry_input,
    keras_init,
    layer_init,
    strided_trunk,
    trunk_length,
)
from flatland_ma.policies.memory import MEMORIES, Memory, each, restart, stack_frames
from flatland_ma.policies.roles import RoleBody, RoleStack, check_roles

__all__ = [
    "BOX",
    "BUILDERS",
    "ActorCritic",
    "PPONetwork",
    "box_entries",
    "build_network",
    # the encoders (policies.encoders), which the baselines import from here too:
    "CONV_CHANNELS",
    "CONV_KERNELS",
    "MAP",
    "STRIDED",
    "FlatInput",
    "ImageInput",
    "MapInput",
    "conv_trunk",
    "entry_input",
    "keras_init",
    "layer_init",
    "strided_trunk",
    "trunk_length",
]

BOX = ""
"""The entry name of an observation that is one ``Box`` (not a ``Dict``)."""


class PPONetwork(nn.Module):
    """Encoders per observation entry - Dense(hidden) [- GRU(memory_size)], then the
    policy's head (every action component's logits, joined) and the value's; orthogonal
    initialisation as in CleanRL. ``entries`` maps each entry of a ``Dict`` observation to
    its shape in the space's order, or is ``{BOX: shape}`` for one ``Box``; ``sizes`` are
    the action components' numbers of choices; ``frames`` how many of the last
    observations it reads, ``memory`` its recurrent core (``policies.memory.MEMORIES``).

    ``step`` acts on one step of every row, given and giving its ``Memory``; ``replay``
    runs whole sequences from a recurrent state; ``logits`` (and ``forward``) read a batch
    of observations each as an episode's first (for a network without memory, simply its
    logits)."""

    kind = "ppo"

    def __init__(
        self,
        entries: Mapping[str, Sequence[int]],
        sizes: Sequence[int],
        hidden: int = 128,
        channels: int = 3,
        network: str = "strided",
        state_size: int = 0,
        memory: str = "none",
        memory_size: int = 128,
        frames: int = 1,
        roles: int = 0,
    ):
        super().__init__()
        if roles:
            check_roles(entries, roles, memory, frames)
        if memory not in MEMORIES:
            raise ValueError(f"memory {memory!r}: one of {', '.join(MEMORIES)}")
        if frames < 1 or memory_size < 1:
            raise ValueError(f"frames {frames}, memory_size {memory_size}: each at least 1")
        self.dict_input = list(entries) != [BOX]
        self.hidden, self.channels, self.network = hidden, channels, network
        self.memory, self.memory_size, self.frames = memory, memory_size, frames
        self.roles = roles
        """Networks, one per role (0: one for every agent)."""
        self.inputs, self.body = _trunk(entries, channels, network, frames, roles, hidden)
        self.core = nn.GRU(hidden, memory_size) if memory == "gru" else None
        """The recurrent core (one layer), or None; orthogonal weights and zero biases (as
        CleanRL's LSTM)."""
        if self.core is not None:
            for name, parameter in self.core.named_parameters():
                init = nn.init.orthogonal_ if name.startswith("weight") else nn.init.zeros_
                init(parameter)
        width = memory_size if self.core is not None else hidden
        """The width of what the heads read (with roles, every role's features and the
        one-hot)."""
        if isinstance(self.body, RoleBody):
            width = self.body.width
        self.sizes = tuple(int(n) for n in sizes)
        bias = not roles  # with roles, the heads read each role's one-hot: its own bias
        self.actor = layer_init(nn.Linear(width, sum(self.sizes), bias=bias), std=0.01)
        self.state_size = state_size
        """The length of the centralised critic's input; 0: the value reads the features."""
        self.critic = _critic(state_size, hidden, width, bias)

    def arguments(self) -> dict:
        """The constructor's arguments besides the spaces, as a checkpoint records them."""
        return {
            "hidden": self.hidden,
            "channels": self.channels,
            "network": self.network,
            "state_size": self.state_size,
            "memory": self.memory,
            "memory_size": self.memory_size,
            "frames": self.frames,
            "roles": self.roles,
        }

    @property
    def remembers(self) -> bool:
        """Whether what it does depends on earlier steps of the episode."""
        return self.core is not None or self.frames > 1

    def features(self, observation) -> torch.Tensor:
        return self.join(self.encodings(observation))

    def encodings(self, observation) -> dict[str, torch.Tensor]:
        """Each entry's encoding, by the entry's key, in the layer's order."""
        if self.dict_input:
            return {key: module(observation[key]) for key, module in self.inputs.items()}
        return {"observation": self.inputs["observation"](observation)}

    def join(self, encodings: dict[str, torch.Tensor]) -> torch.Tensor:
        """What the heads read, from the entries' ``encodings``."""
        if self.roles:
            return self.body(encodings)
        parts = list(encodings.values())
        return self.body(torch.cat(parts, dim=1) if len(parts) > 1 else parts[0])

    def step(
        self, observation, memory: Memory | None = None, starts: torch.Tensor | None = None
    ) -> tuple[torch.Tensor, Memory]:
        """What the heads read for one step of every row, and the rows' memory after it,
        from ``memory`` (None: every row's first step) with the rows where ``starts``
        (batch,) is true beginning an episode."""
        frames = hidden = None
        if self.frames > 1:
            past = None if memory is None else memory.frames
            observation = frames = stack_frames(observation, past, starts, self.frames)
        h = self.features(observation)
        if self.core is not None:
            if memory is None or memory.hidden is None:
                previous = h.new_zeros((h.shape[0], self.memory_size))
            else:
                previous = restart(memory.hidden, starts)
            h = hidden = self.core(h.unsqueeze(0), previous.unsqueeze(0))[0][0]
        return h, Memory(frames, hidden)

    def replay(self, observations, hidden: torch.Tensor | None, starts: torch.Tensor):
        """What the heads read at each step of T steps of B rows: ``observations`` (T, B,
        ...) as ``features`` reads them (frames already stacked), from the recurrent state
        ``hidden`` (B, memory_size) before the first step, restarted where ``starts``
        (T, B) is true; (T, B, width). The core runs over the spans between the steps
        where some row starts an episode, one call each."""
        steps, rows = starts.shape
        h = self.features(each(lambda x: x.flatten(0, 1), observations))
        h = h.unflatten(0, (steps, rows))
        if self.core is None:
            return h
        assert hidden is not None, "a recurrent core replays from its state"
        cuts = [0, *(t for t in starts.any(dim=1).nonzero().flatten().tolist() if t), steps]
        out, state = [], hidden
        for begin, end in zip(cuts[:-1], cuts[1:]):
            span = self.core(h[begin:end], restart(state, starts[begin]).unsqueeze(0))[0]
            out.append(span)
            state = span[-1]
        return torch.cat(out)

    def forward(self, observation) -> torch.Tensor:
        """The policy's logits, every head's joined along the last axis, each row read as
        an episode's first step."""
        return self.actor(self.step(observation)[0])

    def logits(self, observation) -> torch.Tensor:
        return self(observation)


def _trunk(
    entries: Mapping[str, Sequence[int]],
    channels: int,
    network: str,
    frames: int,
    roles: int,
    hidden: int,
) -> tuple[nn.ModuleDict, nn.Module]:
    """``PPONetwork``'s encoders (by entry) and fully connected layer, initialised: one
    for every agent, or with ``roles`` one per role (``policies.roles``)."""

    def encoder(key: str, shape: Sequence[int]) -> nn.Module:
        if not roles or key == ROLE:
            return entry_input(key, shape, channels, network, frames)
        return RoleStack([entry_input(key, shape, channels, network) for _ in range(roles)])

    inputs = nn.ModuleDict(
        {key or "observation": encoder(key, shape) for key, shape in entries.items()}
    )
    features = sum(int(module.features) for module in inputs.values())  # type: ignore[arg-type]
    stacks = {k: m for k, m in inputs.items() if isinstance(m, RoleStack)}
    body = RoleBody(stacks, roles, hidden) if roles else None
    body = body or nn.Sequential(nn.Linear(features, hidden), nn.ReLU())
    for layer in [*inputs.modules(), *body.modules()]:
        if isinstance(layer, (nn.Conv1d, nn.Conv2d, nn.Linear)):
            layer_init(layer)
    return inputs, body


def _critic(state_size: int, hidden: int, width: int, bias: bool) -> nn.Module:
    """The value's head: on ``width`` features, or a centralised critic of its own on a
    global state of ``state_size`` (two layers of ``hidden`` units)."""
    if not state_size:
        return layer_init(nn.Linear(width, 1, bias=bias), std=1.0)
    return nn.Sequential(
        layer_init(nn.Linear(state_size, hidden)),
        nn.ReLU(),
        layer_init(nn.Linear(hidden, hidden)),
        nn.ReLU(),
        layer_init(nn.Linear(hidden, 1), std=1.0),
    )


class ActorCritic(nn.Module):
    """A3C's network: Conv1D(32, 8) - Conv1D(48, 4) - Conv1D(64, 3) - Dense(hidden), ELU
    activations as in universe-starter-agent, then a softmax policy and a value. It reads
    (batch, channels, rays); ``logits`` reads the raw observation (batch, rays, 4) and
    keeps its first ``channels`` channels. Glorot-uniform hidden layers; output rows of
    norm 0.01 (policy) and 1 (value), as that implementation initialises them."""

    kind = "a3c"

    def __init__(self, channels: int, rays: int, actions: int, hidden: int):
        super().__init__()
        if trunk_length(rays) < 1:
            raise ValueError(f"an image of {rays} rays is too short for the paper's trunk")
        self.channels, self.hidden = channels, hidden
        self.body = nn.Sequential(
            conv_trunk(channels, nn.ELU),
            nn.Flatten(),
            nn.Linear(64 * trunk_length(rays), hidden),
            nn.ELU(),
        )
        self.policy = nn.Linear(hidden, actions)
        self.value = nn.Linear(hidden, 1)
        keras_init(self)
        with torch.no_grad():
            for head, norm in ((self.policy, 0.01), (self.value, 1.0)):
                weight = torch.randn_like(head.weight)
                head.weight.copy_(weight * norm / weight.norm(dim=1, keepdim=True))

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h = self.body(x)
        return self.policy(h), self.value(h).squeeze(-1)

    def arguments(self) -> dict:
        return {"channels": self.channels, "hidden": self.hidden}

    def logits(self, observation: torch.Tensor) -> torch.Tensor:
        return self(observation[..., : self.channels].transpose(-1, -2))[0]


def box_entries(observation: dict) -> dict[str, list[int]]:
    """The shape of each entry of an observation space described as JSON (see
    ``policies.checkpoint``): ``{BOX: shape}`` for a ``Box``."""
    if observation["type"] == "Box":
        return {BOX: list(observation["shape"])}
    return {key: list(space["shape"]) for key, space in observation["spaces"].items()}


def _ppo(spaces: dict, arguments: dict) -> nn.Module:
    action = spaces["action"]
    sizes = [action["n"]] if action["type"] == "Discrete" else list(action["nvec"])
    return PPONetwork(box_entries(spaces["observation"]), sizes, **arguments)


def _a3c(spaces: dict, arguments: dict) -> nn.Module:
    observation, action = spaces["observation"], spaces["action"]
    if observation["type"] != "Box" or len(observation["shape"]) != 2:
        raise ValueError("an a3c network reads one Box image of (rays, channels)")
    if action["type"] != "Discrete":
        raise ValueError("an a3c network acts in a Discrete space")
    rays, depth = observation["shape"]
    if arguments["channels"] > depth:
        raise ValueError(f"it reads {arguments['channels']} channels of an image of {depth}")
    return ActorCritic(arguments["channels"], rays, action["n"], arguments["hidden"])


BUILDERS = {"ppo": _ppo, "a3c": _a3c}
"""Network kind -> its maker from (spaces, arguments), both checked JSON."""


def build_network(kind: str, spaces: dict, arguments: dict) -> nn.Module:
    """The network ``kind`` for these spaces and arguments, its tensors on the ``meta``
    device (no memory, no initialisation worth keeping): load its weights with
    ``load_state_dict(..., assign=True)``. ``ValueError`` if the spaces and arguments
    make no such network."""
    with torch.device("meta"):
        return BUILDERS[kind](spaces, arguments)
