"""The JSON schema of scenario files, shipped beside the scenarios as
``scenario.schema.json`` for editors' completion and checks.

It is pydantic's schema of ``ScenarioSpec`` with what the models cannot say themselves:
the loader's ``extends`` key, and the value types many fields share (colours, rectangles)
kept once in ``$defs``. Colours and rectangles carry their own schemas (``types.py``), so
that it describes what files may write rather than how values are stored.
"""

from __future__ import annotations

import json
from typing import Any

from flatland_ma.scenario.colors import COLOR_JSON_SCHEMA
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.scenario.types import RECT_JSON_SCHEMA

DRAFT = "https://json-schema.org/draft/2020-12/schema"
VALUE_TYPES: dict[str, tuple[dict[str, Any], str, str]] = {
    "Color": (COLOR_JSON_SCHEMA, "colour", 'A name, "#rrggbb" or [r, g, b] in 0-255.'),
    "Rect": (
        RECT_JSON_SCHEMA,
        "rectangle `[x0, y0, x1, y1]`",
        "A rectangle [x0, y0, x1, y1]: lower-left, then upper-right corner.",
    ),
}
"""Values (not mappings) that many fields share: their schema, their name in the tables,
and their description. The file schema keeps each once, in ``$defs``."""
EXTENDS: dict[str, Any] = {
    "type": "string",
    "description": "A scenario (a shipped name or a path) this file starts from; the file "
    "merges over it: mappings key by key, anything else replaced whole.",
}
"""``extends`` is read by the loader, not by the models."""
ANNOTATIONS = ("title", "description", "default")
"""Keys of a JSON schema that describe a value rather than constrain it."""


def file_schema() -> dict[str, Any]:
    """The JSON schema of a scenario file: ``ScenarioSpec``'s, with the loader's
    ``extends`` and the shared value types in ``$defs``."""
    schema: dict[str, Any] = ScenarioSpec.model_json_schema()
    for name, (piece, _, description) in VALUE_TYPES.items():
        schema = _share(schema, piece, name)
        schema["$defs"][name] = {**piece, "description": description}
    schema["properties"] = {"extends": EXTENDS, **schema["properties"]}
    schema["title"] = "flatland_ma scenario file"
    schema["description"] = "The keys a scenario file may have at its top."
    return {"$schema": DRAFT, **schema}


def schema_text() -> str:
    """The shipped ``scenario.schema.json``."""
    return json.dumps(file_schema(), indent=2, ensure_ascii=False) + "\n"


def _share(node: Any, piece: dict[str, Any], name: str) -> Any:
    """``node`` with every schema equal to ``piece`` (but for its annotations) replaced by a
    reference to ``$defs/name``; so are ``piece``'s options among a wider ``anyOf`` (pydantic
    flattens ``X | None`` that way)."""
    if isinstance(node, list):
        return [_share(n, piece, name) for n in node]
    if not isinstance(node, dict):
        return node
    ref = {"$ref": f"#/$defs/{name}"}
    if {k: v for k, v in node.items() if k not in ANNOTATIONS} == piece:
        return {**ref, **{k: node[k] for k in ANNOTATIONS if k in node}}
    options, inner = node.get("anyOf"), piece.get("anyOf")
    if options and inner:
        for i in range(len(options) - len(inner) + 1):
            if options[i : i + len(inner)] == inner:
                node = {**node, "anyOf": options[:i] + [ref] + options[i + len(inner) :]}
                break
    return {k: v if k == "default" else _share(v, piece, name) for k, v in node.items()}
