"""The scenario format's reference, written from the schema itself: ``docs/scenarios.md``
for authors and ``scenario.schema.json`` (shipped beside the scenarios) for editors; and,
beside the schema, the shipped scenarios' index (``index.json``, from the files:
``flatland_ma.scenario.shipped``).

    python -m flatland_ma.scenario.reference docs/scenarios.md scenarios/scenario.schema.json

Both come from pydantic's JSON schema of ``ScenarioSpec`` (``json_schema.py``). Every
model reached from the top gets its section here, found by walking that schema (no list
to keep up); every field's type, range and default come from the models, and its meaning
from the docstring under it, so neither can drift from what the loader accepts.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flatland_ma.scenario import budget
from flatland_ma.scenario.colors import NAMED_COLORS_255
from flatland_ma.scenario.index import index_text
from flatland_ma.scenario.json_schema import VALUE_TYPES, file_schema, schema_text
from flatland_ma.scenario.shipped import INDEX_FILE

INTRO = """\
# Scenario files

A scenario is a YAML file: the world (arena, walls, rooms, corridors, doors, zones,
generated layouts, obstacles, items), the agents (how many, their bodies, cameras and
actions), the task (rewards, goals, keys) and the episode length. The shipped ones are in
`scenarios/` (installed as `flatland_ma/scenarios/`), each with the reference solver that
proves it solvable; `flatland-ma list` prints them, `flatland-ma validate FILE...` checks
files.

- **Coordinates**: x to the right, y up, origin at the bottom-left corner of the playing
  area; lengths in world units (the default agent has radius 10), angles in degrees
  counter-clockwise, times in seconds.
- **Rectangles** are `[x0, y0, x1, y1]`: lower-left, then upper-right corner.
- **Colours** are a name (COLOR_NAMES), `"#rrggbb"`, or `[r, g, b]` in 0-255.
- **Every field has a default** unless marked *required*. Unknown keys, wrong types and
  out-of-range values are errors that name the file, the line and the key path, e.g.
  `my.yaml:12: obstacles[2].radius: Input should be greater than or equal to 0.1; got -3`.
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
- **Limits**: arena sides, wall thicknesses and widths are at most 10,000; a file may nest
  32 levels deep and expand (through aliases) to at most 100,000 values. Numbers that
  reach the physics or the rays are physically plausible: lengths (radii, widths,
  thicknesses, texture periods) at least 0.1, masses from 0.001 to 1,000,000, a time step
  from 0.001 to 1 second, top speeds up to 100,000, friction up to 100 (each field's
  table gives its range).
- **Work budget**: what a file asks to be built, after `extends` and overrides, is
  counted before anything is built: at most MAX_SHAPES solid shapes (walls, doors,
  obstacles, agents' parts; a gap splits a wall in two), MAX_SCATTERED obstacles
  scattered at random, MAX_ITEMS items, MAX_GENERATOR_CELLS maze and room-grid cells,
  MAX_KEYS locked doors and keys (key item groups, key objects, switch zones), and
  MAX_GROUPS each of item groups, zones, teams, rules and generators. A reset may also
  draw only so many places, and search only so many grid cells to check what agents can
  reach. A file over a limit gets an error naming it, at the entry that adds the most;
  within them any file loads and resets in seconds.
- **Editor completion**: `scenario.schema.json`, shipped beside the scenarios, is the JSON
  schema of this format, written from the same models as this page (`python -c "import
  flatland_ma.scenario.loader as s; print(s.schema_path())"` prints where it is installed).
  Editors that use yaml-language-server (such as VS Code's YAML extension) complete and
  check the keys of a file that starts with the line
  `# yaml-language-server: $schema=PATH/TO/scenario.schema.json`. The schema sees a file on
  its own: keys it takes from another through `extends`, and the checks of what lies where
  (above), are the loader's.
- **Random draws** (layouts drawn per episode, spawns, respawns, randomly placed zones) all
  come from the generator seeded by `reset(seed=...)`.
- **Versions**: `version` (default 0) names the task's dynamics, rewards and observations.
  A change of any of them, by the file or by the library, bumps it and says so in the
  changelog; the Gymnasium id names it (`flatland_ma/FruitsPoisons-v0`; only the current
  version is registered), benchmark results record it and are never mixed across
  versions, and every shipped scenario's recorded trajectories
  (`tests/data/trajectories/`) hold its current version to the bit.

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


@dataclass
class Section:
    """One table of the reference: the keys of a model, or those that every member of a
    union of models shares alike."""

    key: str
    """The model's name in ``$defs`` (members of a union joined by ``|``; "" for the top)."""
    schema: dict[str, Any]
    """Its JSON schema, with ``properties`` and ``required``."""
    tag: str = ""
    """For a member of a union, its tag, e.g. ``shape: circle``."""
    skip: frozenset[str] = frozenset()
    """Keys left to the union's own section."""
    note: str = ""
    """A sentence after the model's docstring."""
    uses: list[str] = field(default_factory=list)
    """The key paths that lead to it, shortest first, e.g. ``rooms[].openings[]``."""

    @property
    def path(self) -> str:
        return self.uses[0] if self.uses else ""


def sections(schema: dict[str, Any]) -> list[Section]:
    """Every model reached from the top of ``schema``, each after the first one holding it,
    with the key paths that lead to it (found breadth first, so shortest first)."""
    root = Section("", schema)
    found = {"": root}
    queue = [root]
    while queue:
        for use, child in _links(queue.pop(0), schema["$defs"]):
            known = found.setdefault(child.key, child)
            if use not in known.uses:
                known.uses.append(use)
            if known is child:
                queue.append(child)
    order: list[Section] = []

    def walk(section: Section) -> None:
        order.append(section)
        for _, child in _links(section, schema["$defs"]):
            if all(s.key != child.key for s in order):
                walk(found[child.key])

    walk(root)
    return order


def _links(section: Section, defs: dict[str, Any]) -> Iterator[tuple[str, Section]]:
    """The sections that a section's keys lead to, each with its key path."""
    for key, prop in section.schema["properties"].items():
        if key in section.skip:
            continue
        path = f"{section.path}.{key}" if section.path else key
        for suffix, members, tag_key in _refs(prop):
            members = [(n, tag) for n, tag in members if defs[n].get("type") == "object"]
            if tag_key is None:
                yield from ((path + suffix, Section(n, defs[n])) for n, _ in members)
                continue
            shared = _shared_keys([defs[n] for n, _ in members], tag_key)
            if shared:
                first = defs[members[0][0]]
                union = {
                    "properties": {k: first["properties"][k] for k in shared},
                    "required": [k for k in first.get("required", []) if k in shared],
                }
                note = f"Every entry has these keys, and those of its `{tag_key}`."
                key = "|".join(n for n, _ in members)
                yield path + suffix, Section(key, union, note=note)
            for name, tag in members:
                yield (
                    path + suffix,
                    Section(name, defs[name], tag=f"{tag_key}: {tag}", skip=frozenset(shared)),
                )


Members = list[tuple[str, str]]
"""Models in ``$defs`` with their tags (empty outside a tagged union)."""


def _refs(prop: dict[str, Any], suffix: str = "") -> Iterator[tuple[str, Members, str | None]]:
    """The models a key's schema holds: (``[]`` per list level and ``.*`` per mapping of
    names, the models with their tags, the tag key if they are a tagged union's members)."""
    if "$ref" in prop:
        yield suffix, [(_name(prop["$ref"]), "")], None
    elif "discriminator" in prop:
        tags: dict[str, list[str]] = {}
        for tag, ref in prop["discriminator"].get("mapping", {}).items():
            tags.setdefault(_name(ref), []).append(str(tag))
        names = [_name(option["$ref"]) for option in prop["oneOf"] if "$ref" in option]
        members = [(n, " / ".join(tags.get(n, ["..."]))) for n in names]
        yield suffix, members, prop["discriminator"]["propertyName"]
    for option in prop.get("anyOf", []):
        yield from _refs(option, suffix)
    if isinstance(prop.get("items"), dict):
        yield from _refs(prop["items"], suffix + "[]")
    if isinstance(prop.get("additionalProperties"), dict):
        yield from _refs(prop["additionalProperties"], suffix + ".*")


def _name(ref: str) -> str:
    return ref.rsplit("/", 1)[-1]


def _shared_keys(members: list[dict[str, Any]], tag_key: str) -> list[str]:
    """The keys (but the tag) that every member of a union has, with the same schema."""
    first, *others = members
    return [
        k
        for k, v in first["properties"].items()
        if k != tag_key and all(o["properties"].get(k) == v for o in others)
    ]


def render() -> str:
    """``docs/scenarios.md``."""
    names = ", ".join(sorted(NAMED_COLORS_255))
    intro = INTRO.replace("COLOR_NAMES", names)
    limits = ("MAX_SHAPES", "MAX_SCATTERED", "MAX_ITEMS", "MAX_GENERATOR_CELLS", "MAX_KEYS")
    for name in (*limits, "MAX_GROUPS"):
        intro = intro.replace(name, f"{getattr(budget, name):,}")
    parts = [intro]
    parts += [_table(section) for section in sections(file_schema())]
    return "\n".join(parts)


def _table(section: Section) -> str:
    lines = [f"## {_title(section)}", ""]
    for text in (section.schema.get("description", ""), section.note, _where(section)):
        if text:
            lines += [" ".join(text.split()), ""]
    lines += ["| key | type | default | meaning |", "|---|---|---|---|"]
    required = section.schema.get("required", [])
    for key, prop in section.schema["properties"].items():
        if key in section.skip:
            continue
        meaning = " ".join(prop.get("description", "").split()).replace("|", "\\|")
        default = "*required*" if key in required else _default(prop)
        lines.append(f"| `{key}` | {_describe(prop)} | {default} | {meaning} |")
    return "\n".join(lines) + "\n"


def _title(section: Section) -> str:
    if not section.uses:
        return "Top level"
    key = _common_key(section)
    title = f"`{key}`" if key else " and ".join(f"`{use}`" for use in section.uses)
    return title + (f" with `{section.tag}`" if section.tag else "")


def _where(section: Section) -> str:
    """For a model under one key in many places: those places."""
    key = _common_key(section)
    if not key:
        return ""
    places = ", ".join(f"`{use.rsplit('.', 1)[0]}`" for use in section.uses)
    return f"The `{key}` of {places}."


def _common_key(section: Section) -> str | None:
    """The key a model is under, when it is under the same key in more than two places."""
    keys = {use.rsplit(".", 1)[-1] for use in section.uses}
    return keys.pop() if len(section.uses) > 2 and len(keys) == 1 else None


def _describe(prop: dict[str, Any]) -> str:
    """A key's type in words, with its bounds."""
    if "$ref" in prop:
        name = _name(prop["$ref"])
        return VALUE_TYPES[name][1] if name in VALUE_TYPES else "mapping"
    if "discriminator" in prop:
        return "mapping"
    if "const" in prop:
        return f"`{prop['const']}`"
    if "enum" in prop:
        return "one of " + ", ".join(f"`{v}`" for v in prop["enum"])
    if "anyOf" in prop:
        options = [o for o in prop["anyOf"] if o.get("type") != "null"]
        null = " or null" if len(options) < len(prop["anyOf"]) else ""
        return " or ".join(_describe(o) for o in options) + null
    kind = prop.get("type", "")
    if kind == "array" and "prefixItems" in prop:
        inner = [_describe(item) for item in prop["prefixItems"]]
        if len(set(inner)) == 1:
            return f"[{len(inner)} x {inner[0]}]"
        return "[" + ", ".join(inner) + "]"
    if kind == "array":
        return f"list of {_describe(prop.get('items', {}))}" + _length(prop)
    if kind == "object" and isinstance(prop.get("additionalProperties"), dict):
        return f"mapping of names to {_describe(prop['additionalProperties'])}"
    if kind == "string":
        return ("name" if "pattern" in prop else "text") + _bounds(prop)
    words = {"boolean": "true / false", "integer": "integer", "number": "number"}
    return words.get(kind, "mapping" if kind == "object" else "anything") + _bounds(prop)


def _bounds(prop: dict[str, Any]) -> str:
    signs = [
        ("exclusiveMinimum", ">"),
        ("minimum", ">="),
        ("exclusiveMaximum", "<"),
        ("maximum", "<="),
    ]
    marks = [f"{sign} {_number(prop[key])}" for key, sign in signs if key in prop]
    return f" ({', '.join(marks)})" if marks else ""


def _length(prop: dict[str, Any]) -> str:
    marks = []
    if prop.get("minItems"):
        marks.append(f"at least {_number(prop['minItems'])}")
    if "maxItems" in prop:
        marks.append(f"at most {_number(prop['maxItems'])}")
    return f" ({', '.join(marks)})" if marks else ""


def _number(value: float) -> str:
    return f"{int(value):,}" if float(value).is_integer() else f"{value:g}"


def _default(prop: dict[str, Any]) -> str:
    value = prop.get("default")
    if value is None:
        return "none"
    if value == {}:
        return "`{}`"
    if isinstance(value, dict):
        return "see its section"
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        return "one entry (see its section)" if len(value) == 1 else "see its section"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if value == "":
        return '`""`'
    if isinstance(value, list):
        return "`[" + ", ".join(_scalar(v) for v in value) + "]`"
    return f"`{_scalar(value)}`"


def _scalar(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").partition("\n")[0])
    parser.add_argument("markdown", type=Path, help="where to write the reference")
    parser.add_argument("schema", type=Path, help="where to write the JSON schema")
    args = parser.parse_args(argv)
    args.markdown.write_text(render(), encoding="utf-8")
    args.schema.write_text(schema_text(), encoding="utf-8")
    (args.schema.parent / INDEX_FILE).write_text(index_text(args.schema.parent), encoding="utf-8")


if __name__ == "__main__":
    main()
