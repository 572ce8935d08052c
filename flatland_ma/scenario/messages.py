"""pydantic's validation errors as located problems: the data's key path (without the
union tags pydantic adds), the file and line it was written at, and one clear message."""

from __future__ import annotations

import difflib
import reprlib
import types
import typing
from collections.abc import Sequence
from typing import Any

from pydantic import BaseModel
from pydantic_core import ErrorDetails

from flatland_ma.scenario.errors import KeyPath, Marks, Problem, SpecError, locate
from flatland_ma.scenario.kinds import Nested

TAG_KEYS = ("shape", "generator", "rule", "type")
"""Keys whose value picks the model of a mapping (pydantic puts it in error locations)."""


def problems_from(
    errors: Sequence[ErrorDetails], root: type[BaseModel], raw: dict, marks: Marks, fallback: str
) -> list[Problem]:
    """Every pydantic error as a ``Problem``; the errors of the alternatives of one union
    (e.g. ``respawn: 0``, neither a word nor a count) become one problem."""
    # key path -> messages, or the errors of a union
    faults: dict[KeyPath, list[str | ErrorDetails]] = {}
    _collect(errors, root, raw, (), faults)
    problems: list[Problem] = []
    for path, found in faults.items():
        union = [e for e in found if isinstance(e, dict)]
        messages = [m for m in found if isinstance(m, str)] + (
            [_union_message(union)] if union else []
        )
        problems += [locate(marks, path, message, fallback) for message in messages]
    return problems


def _collect(
    errors: Sequence[ErrorDetails],
    root: type[BaseModel],
    raw: Any,
    prefix: KeyPath,
    faults: dict[KeyPath, list[str | ErrorDetails]],
) -> None:
    """Sort the errors of ``root`` validating ``raw`` (found at ``prefix``) by key path. A
    registered spec's errors (``kinds.Nested``) are sorted within their entry."""
    for error in errors:
        cause = (error.get("ctx") or {}).get("error")
        if isinstance(cause, SpecError):
            for path, message in [(cause.path, str(cause)), *cause.also]:
                faults.setdefault(tuple(path), []).append(message)
            continue
        path = _data_path(tuple(error["loc"]), raw)
        if isinstance(cause, Nested):
            _collect(cause.errors, cause.model, _value_at(raw, path), prefix + path, faults)
            continue
        faults.setdefault(prefix + path, []).append(
            error if _is_branch(error, path) else _message(error, root)
        )


def _value_at(raw: Any, path: KeyPath) -> Any:
    """The value at ``path`` (a path ``_data_path`` found in ``raw``)."""
    for part in path:
        raw = raw[part]
    return raw


def _is_branch(error: ErrorDetails, path: KeyPath) -> bool:
    """Whether the error is one alternative's of a union: its location ends in the name
    of the alternative (``int``, ``literal[...]``), which is not a key of the data."""
    last = error["loc"][-1] if error["loc"] else None
    return (
        error["type"] not in ("missing", "extra_forbidden")
        and isinstance(last, str)
        and (not path or last != path[-1])
    )


def _union_message(errors: list[ErrorDetails]) -> str:
    texts = []
    for error in errors:
        text = error["msg"].removeprefix("Value error, ")
        if texts and text.startswith("Input should be "):
            text = text.removeprefix("Input should be ")
        if text not in texts:
            texts.append(text)
    return f"{', or '.join(texts)}; got {_shown(errors[0].get('input'))}"


def _message(error: ErrorDetails, root: type[BaseModel]) -> str:
    loc = tuple(error["loc"])
    kind = error["type"]
    if kind == "extra_forbidden":
        allowed = sorted(_model_at(root, loc[:-1]).model_fields)
        hint = difflib.get_close_matches(str(loc[-1]), allowed, n=1)
        maybe = f" (did you mean {hint[0]!r}?)" if hint else ""
        return f"unknown key {loc[-1]!r}{maybe}; allowed keys: {', '.join(allowed)}"
    if kind == "missing" and isinstance(loc[-1], int):
        return f"too few items: item [{loc[-1]}] is missing"
    if kind == "missing":
        return f"missing required key {loc[-1]!r}"
    text = error["msg"].removeprefix("Value error, ")
    return text if kind == "value_error" else f"{text}; got {_shown(error.get('input'))}"


SHOWN = 120
"""The most characters of a wrong value a message repeats."""
_REPR = reprlib.Repr()
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = 8
_REPR.maxstring = _REPR.maxother = SHOWN


def _shown(value) -> str:
    """The value as the message shows it, cut short if long (a list of thousands, a huge
    string)."""
    text = _REPR.repr(value)
    return text if len(text) <= SHOWN else text[: SHOWN - 3] + "..."


def _data_path(loc: tuple, raw: Any) -> KeyPath:
    """Drop the parts of a pydantic location that are not keys of the data (union tags)."""
    path: list = []
    node = raw
    for part in loc:
        if isinstance(node, dict) and part in node:
            node = node[part]
            path.append(part)
        elif isinstance(node, (list, tuple)) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
            path.append(part)
        elif isinstance(node, dict) and isinstance(part, str) and not _is_tag(part, node):
            path.append(part)  # a missing or unknown key: report at the key itself
            break
    return tuple(path)


def _is_tag(part: str, node: dict) -> bool:
    return any(node.get(k) == part for k in TAG_KEYS)


def _model_at(root: type[BaseModel], loc: tuple) -> type[BaseModel]:
    """The model class that validates the mapping at ``loc`` (for listing its keys)."""
    model: Any = root
    for part in loc:
        if isinstance(part, int):
            continue
        fields = getattr(model, "model_fields", {})
        if part in fields:
            model = _inner_model(fields[part].annotation)
        else:  # a discriminator tag: pick the union member whose tag matches
            model = _member_with_tag(model, part) or model
    return model if isinstance(model, type) and issubclass(model, BaseModel) else root


def _inner_model(annotation: Any) -> Any:
    while True:
        origin = typing.get_origin(annotation)
        args = typing.get_args(annotation)
        present = [a for a in args if a is not type(None)]
        if origin is typing.Annotated:
            annotation = args[0]
        elif origin in (tuple, list) and args:
            annotation = args[0]
        elif origin in (typing.Union, types.UnionType) and len(present) == 1:
            annotation = present[0]  # an optional section, e.g. ``head: HeadSpec | None``
        else:
            return annotation


def _member_with_tag(union: Any, tag: str) -> Any:
    for member in typing.get_args(union):
        fields = getattr(member, "model_fields", {})
        for name in TAG_KEYS:
            if name in fields and tag in typing.get_args(fields[name].annotation):
                return member
    return None
