"""What a checkpoint's JSON description may say: a strict spec, checked when it is read
(and before it is written), every fault named by the file and the entry's key path.

The description (the safetensors file's ``__metadata__["flatland_ma"]``) holds::

    format: "flatland_ma.policy", version: 2
    scenario, observation_space, action_space   the scenario and the spaces as text (str)
    spaces: {observation: Box | Dict of Box, action: Discrete | MultiDiscrete}   as JSON
    action_sizes                                the choices of each action component
    network: {kind: "ppo" | "a3c", arguments: {...}}   rebuilt by policies.networks
                                                (ppo's memory, frames and roles default
                                                to none, 1 and 0, as before they existed)
    padded, trained_with, overrides, algorithm, args, update, agent_steps   (optional)
    optimizer                                   the trainer's optimiser state (optional)

A space is ``{"type": "Box", "shape": [64, 4], "dtype": "float32"}``, ``{"type": "Dict",
"spaces": {key: Box, ...}}`` (in the space's order), ``{"type": "Discrete", "n": 3}`` or
``{"type": "MultiDiscrete", "nvec": [3, 2]}``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, JsonValue, ValidationError, model_validator

FORMAT = "flatland_ma.policy"
VERSION = 2
"""1: a ``torch.save`` pickle holding a ``torch.export`` program (refused: it could run
code); 2: safetensors weights with this JSON description."""
METADATA_KEY = "flatland_ma"
MAX_SIZE = 2**16
"""The largest extent of an observation axis, and the most choices of an action."""
MAX_OBSERVATION_VALUES = 2**22
"""The most values one observation may hold, every entry together (16 MiB as float32):
a 256 x 256 top-down map of every channel takes a tenth of it, the shipped scenarios at
most 12,288. A checkpoint is probed with one observation of the shape it describes, so
this bounds what loading it may allocate (its weights are bounded by the file's size)."""

Size = Annotated[int, Field(ge=1, le=MAX_SIZE)]


class _Strict(BaseModel):
    model_config = ConfigDict(strict=True, frozen=True, extra="forbid")


class BoxSpace(_Strict):
    type: Literal["Box"]
    shape: Annotated[list[Size], Field(min_length=1, max_length=3)]
    dtype: Literal["float32", "float64", "float16", "uint8", "int8", "int16", "int32", "int64"]


class DictSpace(_Strict):
    type: Literal["Dict"]
    spaces: Annotated[dict[str, BoxSpace], Field(min_length=1, max_length=64)]


class DiscreteSpace(_Strict):
    type: Literal["Discrete"]
    n: Size


class MultiDiscreteSpace(_Strict):
    type: Literal["MultiDiscrete"]
    nvec: Annotated[list[Size], Field(min_length=1, max_length=64)]


class Spaces(_Strict):
    observation: Annotated[BoxSpace | DictSpace, Field(discriminator="type")]
    action: Annotated[DiscreteSpace | MultiDiscreteSpace, Field(discriminator="type")]

    @model_validator(mode="after")
    def _observation_within_the_limit(self):
        values = observation_values(self.observation.model_dump())
        if values > MAX_OBSERVATION_VALUES:
            raise ValueError(
                f"an observation of {values:,} values; a checkpoint's network reads at most "
                f"{MAX_OBSERVATION_VALUES:,}"
            )
        return self

    def action_sizes(self) -> list[int]:
        action = self.action
        return [action.n] if isinstance(action, DiscreteSpace) else list(action.nvec)


Hidden = Annotated[int, Field(ge=1, le=4096)]
MAX_FRAMES = 64
"""The most observations a network may read at once (``frames``)."""
Channels = Annotated[int, Field(ge=1, le=64)]
MAX_ROLES = 64
"""The most roles a network may have a part for (each costs a whole network's work)."""


class PPOArguments(_Strict):
    hidden: Hidden
    channels: Channels
    network: Literal["strided", "paper"]
    state_size: Annotated[int, Field(ge=0, le=2**20)]
    memory: Literal["none", "gru"] = "none"
    """The recurrent core after the fully connected layer (checkpoints before it: none)."""
    memory_size: Hidden = 128
    """The recurrent core's units (read only with a core)."""
    frames: Annotated[int, Field(ge=1, le=MAX_FRAMES)] = 1
    """How many of the last observations the network reads (before it: one)."""
    roles: Annotated[int, Field(ge=0, le=MAX_ROLES)] = 0
    """Networks, one per role of a padded observation (before it: 0, one for all)."""


class A3CArguments(_Strict):
    channels: Channels
    hidden: Hidden


class PPONetworkSpec(_Strict):
    kind: Literal["ppo"]
    arguments: PPOArguments


class A3CNetworkSpec(_Strict):
    kind: Literal["a3c"]
    arguments: A3CArguments


Count = Annotated[int, Field(ge=0)]


class Progress(_Strict):
    """Where a training run stood at a checkpoint, for going on from it (``baselines.ppo
    --resume``): its episodes, CPU and wall seconds so far, the agent-steps at which it
    was resumed before, and at which each stage of its curriculum began."""

    episodes: Count
    cpu_seconds: Annotated[float, Field(ge=0, allow_inf_nan=False)]
    wall_seconds: Annotated[float, Field(ge=0, allow_inf_nan=False)]
    resumed_at: Annotated[list[Count], Field(max_length=100_000)] = []
    began: Annotated[list[Count], Field(min_length=1, max_length=100_000)] = [0]


class CheckpointSpec(_Strict):
    format: Literal["flatland_ma.policy"]
    version: Literal[2]
    scenario: Annotated[str, Field(min_length=1, max_length=4096)]
    observation_space: Annotated[str, Field(max_length=2**16)]
    action_space: Annotated[str, Field(max_length=2**16)]
    spaces: Spaces
    action_sizes: Annotated[list[Size], Field(min_length=1, max_length=64)]
    network: Annotated[PPONetworkSpec | A3CNetworkSpec, Field(discriminator="kind")]
    padded: bool = False
    trained_with: list[str] = []
    overrides: dict[str, JsonValue] = {}
    algorithm: str | None = None
    args: dict[str, JsonValue] = {}
    update: Annotated[int, Field(ge=0)] | None = None
    agent_steps: Annotated[int, Field(ge=0)] | None = None
    progress: Progress | None = None
    optimizer: JsonValue = None

    @model_validator(mode="after")
    def _sizes_fit_the_action_space(self):
        if self.action_sizes != self.spaces.action_sizes():
            raise ValueError(
                f"action_sizes {self.action_sizes} disagree with the action space "
                f"{self.spaces.action.model_dump()}"
            )
        return self


def observation_values(observation: dict) -> int:
    """The values one observation of a described space holds (every entry's together)."""
    if observation["type"] == "Box":
        return math.prod(observation["shape"])
    return sum(math.prod(space["shape"]) for space in observation["spaces"].values())


def check_description(path: str | Path, data: Any) -> dict:
    """``data`` (parsed JSON) as a checked description, a plain dict; ``ValueError``
    naming ``path`` and each faulty entry."""
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError(f"{path}: not a flatland_ma policy checkpoint")
    if data.get("version") != VERSION:
        raise ValueError(
            f"{path}: checkpoint version {data.get('version')!r}, this flatland_ma reads {VERSION}"
        )
    try:
        return CheckpointSpec.model_validate(data).model_dump()
    except ValidationError as err:
        faults = [
            f"{'.'.join(str(part) for part in e['loc']) or 'description'}: {e['msg']}"
            for e in err.errors()[:5]
        ]
        raise ValueError(f"{path}: " + "; ".join(faults)) from None


def space_description(space: Any) -> dict:
    """A gymnasium space as the description's JSON (``ValueError`` for other spaces)."""
    from gymnasium import spaces

    if isinstance(space, spaces.Box):
        return {"type": "Box", "shape": list(space.shape), "dtype": str(space.dtype)}
    if isinstance(space, spaces.Dict):
        return {
            "type": "Dict",
            "spaces": {key: space_description(sub) for key, sub in space.spaces.items()},
        }
    if isinstance(space, spaces.Discrete):
        return {"type": "Discrete", "n": int(space.n)}
    if isinstance(space, spaces.MultiDiscrete) and space.nvec.ndim == 1:
        return {"type": "MultiDiscrete", "nvec": [int(n) for n in space.nvec]}
    raise ValueError(f"a checkpoint keeps Box, Dict, Discrete or MultiDiscrete spaces, not {space}")
