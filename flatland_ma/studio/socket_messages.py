"""The messages a page sends over an episode's WebSocket, checked strictly (pydantic):
an unknown type or key, a wrong type or a value out of range is an error message back,
never an exception in the server.

======  ==========================================================================
type    keys
======  ==========================================================================
start   mode (watch | play), scenario (a reference) or text (YAML) with folder,
        seed, policies (agent -> policy, watch; an agent left out plays its default),
        others (policy, play; none: each its default), fps, image
play    (watch) run at the current speed
pause   (watch) stop; ``step`` advances one step
speed   fps: frames (steps) a second
reset   seed: start the episode again
keys    held: keys held now; pressed: keys that went down since the last message
alive   nothing: the page is still there (an episode's page that says nothing for
        ``limits.idle_episode_seconds`` loses its episode)
======  ==========================================================================
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StringConstraints,
    TypeAdapter,
    ValidationError,
)

from flatland_ma.studio.config import MAX_SEED

Key = Annotated[str, StringConstraints(min_length=1, max_length=16, pattern=r"^[a-z0-9]+$")]
Name = Annotated[str, StringConstraints(min_length=1, max_length=240)]
Seed = Annotated[int, Field(ge=0, le=MAX_SEED, strict=True)]
MAX_TEXT = 512 * 1024
MAX_AGENTS = 256


class _Message(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Start(_Message):
    type: Literal["start"]
    mode: Literal["watch", "play"] = "watch"
    scenario: Name | None = None
    text: Annotated[str, StringConstraints(max_length=MAX_TEXT)] | None = None
    folder: Annotated[int, Field(ge=0, le=999, strict=True)] | None = None
    seed: Seed = 0
    policies: Annotated[dict[Name, Name], Field(max_length=MAX_AGENTS)] = {}
    others: Name | None = None
    fps: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 10.0
    image: Literal["jpeg", "png"] = "jpeg"


class Control(_Message):
    type: Literal["play", "pause", "step", "alive"]


class Speed(_Message):
    type: Literal["speed"]
    fps: Annotated[float, Field(gt=0, allow_inf_nan=False)]


class Reset(_Message):
    type: Literal["reset"]
    seed: Seed = 0


class KeysMessage(_Message):
    type: Literal["keys"]
    held: Annotated[list[Key], Field(max_length=16)] = []
    pressed: Annotated[list[Key], Field(max_length=16)] = []


Message = Annotated[Start | Control | Speed | Reset | KeysMessage, Field(discriminator="type")]
MESSAGE = TypeAdapter(Message)


def parse(text: str) -> Start | Control | Speed | Reset | KeysMessage:
    """A message from its JSON text (``pydantic.ValidationError`` if it is none)."""
    return MESSAGE.validate_json(text)


def error_text(err: Exception) -> str:
    """A short account of a refused message."""
    if isinstance(err, ValidationError):
        parts = []
        for item in err.errors()[:4]:
            where = ".".join(str(p) for p in item.get("loc", ()))
            parts.append(f"{where}: {item.get('msg')}" if where else str(item.get("msg")))
        return "bad message: " + "; ".join(parts)
    return f"bad message: {err}"
