"""The scenario format reference (``docs/scenarios.md``), written from the schema itself.

    python -m flatland_ma.scenario.reference > docs/scenarios.md

Every field's type, range and default come from the models, and its meaning from the
docstring under it, so the reference cannot drift from what the loader accepts.
"""

from __future__ import annotations

import types
import typing
from typing import Annotated, Literal, Union

import annotated_types as at
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from flatland_ma.scenario import schema as s
from flatland_ma.scenario.colors import NAMED_COLORS_255, parse_color

SECTIONS: list[tuple[str, type[BaseModel], str]] = [
    ("Top level", s.ScenarioSpec, "The keys a scenario file may have at its top."),
    ("episode", s.EpisodeSpec, ""),
    ("physics", s.PhysicsSpec, ""),
    ("arena", s.ArenaSpec, ""),
    ("arena.wall", s.WallStyle, "The look of the boundary walls, and the default of every wall."),
    ("walls[]", s.WallSpec, ""),
    ("rooms[]", s.RoomSpec, ""),
    ("rooms[].openings[]", s.OpeningSpec, ""),
    ("corridors[]", s.CorridorSpec, ""),
    ("doors[] and openings[].door", s.DoorSpec, ""),
    ("zones[]", s.ZoneSpec, ""),
    ("layout", s.LayoutSpec, ""),
    ("layout.generators[]: grid_rooms", s.GridRoomsSpec, ""),
    ("layout.generators[]: maze", s.MazeSpec, ""),
    ("layout.generators[]: random_obstacles", s.RandomObstaclesSpec, ""),
    ("obstacles[]", s.ObstacleBase, "Every obstacle has these keys, and those of its `shape`."),
    ("obstacles[]: circle", s.CircleObstacle, ""),
    ("obstacles[]: box", s.BoxObstacle, ""),
    ("obstacles[]: polygon", s.PolygonObstacle, ""),
    ("items[]", s.ItemSpec, ""),
    ("texture", s.TextureSpec, ""),
    ("agent", s.AgentSpec, "The body, motor, camera and start of every agent."),
    ("agent.spawn", s.SpawnSpec, ""),
    ("agent.camera and agent.sensors[]: camera", s.CameraSpec, ""),
    ("agent.head", s.HeadSpec, ""),
    ("agent.arms[]", s.ArmSpec, ""),
    ("agent.arms[].segments[]", s.ArmSegmentSpec, ""),
    ("agent.arms[].grasper", s.GrasperSpec, ""),
    ("teams[]", s.TeamSpec, ""),
    ("rules[]: step_reward", s.StepRewardSpec, ""),
    ("rules[]: contact_reward", s.ContactRewardSpec, ""),
]

INTRO = """\
# Scenario files

A scenario is a YAML file: the world (arena, walls, rooms, corridors, doors, zones,
generated layouts, obstacles, items), the agents (how many, their bodies, cameras and
actions), the task (rewards, goals, keys) and the episode length. The shipped ones are in
`flatland_ma/scenarios/`; `flatland-ma list` prints them, `flatland-ma validate FILE...`
checks files.

- **Coordinates**: x to the right, y up, origin at the bottom-left corner of the playing
  area; lengths in world units (the default agent has radius 10), angles in degrees
  counter-clockwise, times in seconds.
- **Rectangles** are `[x0, y0, x1, y1]`: lower-left, then upper-right corner.
- **Colours** are a name (COLOR_NAMES), `"#rrggbb"`, or `[r, g, b]` in 0-255.
- **Every field has a default** unless marked *required*. Unknown keys, wrong types and
  out-of-range values are errors that name the file, the line and the key path, e.g.
  `my.yaml:12: obstacles[2].radius: Input should be greater than 0; got -3`.
- **`extends: NAME`** at the top starts from another scenario (a shipped name or a path)
  and merges this file over it: mappings key by key, anything else (lists included)
  replaced whole.
- **Overrides from Python** merge the same way and are validated the same way:
  `flatland_ma.parallel_env("maze_goal", n_agents=2, agent={"camera": {"rays": 128}})`.
- **What is checked before anything runs**: walls, corridors, doors, rooms, obstacles,
  zones and spawn areas inside the arena (wall ends may reach into the boundary walls);
  room openings inside their sides; obstacles overlapping nothing and fixed items not
  overlapping each other; agents,
  items and maze cells big enough for what must fit; every item and zone reachable by the
  agents (walls and fixed obstacles block; locked and switched doors block until their key
  or switch zone can be reached, and a key or switch zone placed at random must be
  reachable without the door it opens); keys and switches that exist; walls thick enough
  that the agents' top speed cannot carry them through; and room to spare for what is
  placed at random (the scenario is built with several seeds, and discs placed at random
  may cover at most 30% of the free floor they are drawn on).
- **Limits**: arena sides, wall thicknesses and widths are at most 10,000; a maze has at
  most 10,000 cells; a file may nest 32 levels deep and expand (through aliases) to at
  most 100,000 values.
- **Random draws** (layouts drawn per episode, spawns, respawns, randomly placed zones) all
  come from the generator seeded by `reset(seed=...)`.

## Example

```yaml
# A comment saying what the task is, what makes it hard, and the scores of random and
# scripted play.
description: "Take the key, open the locked door with it, reach the goal behind it."
arena: {size: [400, 250]}
walls:
  - {start: [250, 0], end: [250, 250], thickness: 8}
doors:
  - {start: [250, 105], end: [250, 145], state: locked, key: key, color: red}
items:
  - {name: key, color: gold, reward: 1, key: true, respawn: never, spawn: [20, 20, 230, 230]}
  - {name: goal, color: lime, reward: 10, terminal: true, positions: [[340, 125]]}
agent:
  spawn: {area: [20, 20, 230, 230]}
episode: {max_steps: 500}
```
"""


def render() -> str:
    names = ", ".join(sorted(NAMED_COLORS_255))
    parts = [INTRO.replace("COLOR_NAMES", names)]
    for title, model, intro in SECTIONS:
        parts.append(_section(title, model, intro))
    return "\n".join(parts)


def _section(title: str, model: type[BaseModel], intro: str) -> str:
    doc = " ".join((model.__doc__ or "").split()) if model.__doc__ != BaseModel.__doc__ else ""
    lines = [f"## `{title}`", ""]
    for text in (doc, intro):
        if text and not text.startswith("Base of every"):
            lines += [text, ""]
    lines += ["| key | type | default | meaning |", "|---|---|---|---|"]
    shared = model is not s.ObstacleBase and issubclass(model, s.ObstacleBase)
    skip = set(s.ObstacleBase.model_fields) if shared else set()
    for name, field in model.model_fields.items():
        if name in skip:
            continue
        kind = _describe(field.annotation, field.metadata)
        meaning = " ".join((field.description or "").split()).replace("|", "\\|")
        lines.append(f"| `{name}` | {kind} | {_default(field)} | {meaning} |")
    return "\n".join(lines) + "\n"


def _default(field: FieldInfo) -> str:
    if field.is_required():
        return "*required*"
    value = field.default
    if isinstance(value, BaseModel):
        return "see its section"
    if value is None:
        return "none"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, float):
        return f"`{value:g}`"
    if value == "":
        return '`""`'
    if isinstance(value, tuple):
        return (
            "`[" + ", ".join(str(v) if not isinstance(v, float) else f"{v:g}" for v in value) + "]`"
        )
    return f"`{value}`"


def _describe(annotation, metadata=()) -> str:
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if any(getattr(m, "func", None) is parse_color for m in metadata):
        return "colour"
    if any(getattr(getattr(m, "func", None), "__name__", "") == "_ordered" for m in metadata):
        return "rectangle `[x0, y0, x1, y1]`"
    if origin is Annotated:
        extra = []
        for meta in args[1:]:
            extra += meta.metadata if isinstance(meta, FieldInfo) else [meta]
        return _describe(args[0], list(metadata) + extra)
    if origin in (Union, types.UnionType):
        options = [a for a in args if a is not type(None)]
        models = [a for a in options if isinstance(a, type) and issubclass(a, BaseModel)]
        if len(models) > 1 and len(models) == len(options):
            return "mapping"
        text = " or ".join(_describe(a, metadata) for a in options)
        return text + (" or null" if len(options) < len(args) else "")
    if origin is Literal:
        return "one of " + ", ".join(f"`{a}`" for a in args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"list of {_describe(args[0])}" + _length(metadata)
        inner = [_describe(a) for a in args]
        if len(set(inner)) == 1:
            return f"[{len(inner)} x {inner[0]}]"
        return "[" + ", ".join(inner) + "]"
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "mapping"
    names = {bool: "true / false", int: "integer", float: "number", str: "text"}
    text = names.get(annotation, getattr(annotation, "__name__", str(annotation)))
    if annotation is str and any(getattr(m, "pattern", None) for m in metadata):
        text = "name"
    return text + _bounds(metadata)


def _bounds(metadata) -> str:
    marks = []
    for m in metadata:
        for cls, sign, attr in (
            (at.Gt, ">", "gt"),
            (at.Ge, ">=", "ge"),
            (at.Lt, "<", "lt"),
            (at.Le, "<=", "le"),
        ):
            if isinstance(m, cls):
                value = getattr(m, attr)
                shown = f"{int(value):,}" if float(value).is_integer() else f"{value:g}"
                marks.append(f"{sign} {shown}")
    return f" ({', '.join(marks)})" if marks else ""


def _length(metadata) -> str:
    for m in metadata:
        if isinstance(m, at.MinLen) and m.min_length:
            return f" (at least {m.min_length})"
    return ""


if __name__ == "__main__":
    print(render(), end="")
