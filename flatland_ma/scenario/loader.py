"""Reading scenario files into a validated ``ScenarioSpec``.

A file is YAML. ``extends: NAME`` at its top starts from another scenario and merges this
file's keys over it. Keyword overrides from Python are merged last. Mappings merge key by
key; any other value (lists included) replaces what was there. Every fault is reported
with the file, the line and the key path it concerns.
"""

from __future__ import annotations

import difflib
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError

from flatland_ma.scenario.errors import KeyPath, Problem, ScenarioError, SpecError
from flatland_ma.scenario.schema import ScenarioSpec

SCENARIO_SUFFIXES = (".yaml", ".yml")
OVERRIDES = "<overrides>"
_MAX_DEPTH = 32
_MAX_EXTENDS = 8

# For each key path: the file and 1-based line where its value was written.
Marks = dict[KeyPath, tuple[str, int | None]]


def scenario_dir() -> Path:
    """The folder of scenario files shipped with the package."""
    return Path(__file__).resolve().parent.parent / "scenarios"


def list_scenarios() -> list[str]:
    """Names of the scenarios shipped with the package, sorted."""
    return sorted(p.stem for p in scenario_dir().iterdir() if p.suffix in SCENARIO_SUFFIXES)


def scenario_path(name: str | Path) -> Path:
    """The file of a shipped scenario, or ``name`` itself if it is a path to a file."""
    path = Path(name)
    if path.suffix in SCENARIO_SUFFIXES or path.is_file():
        if not path.is_file():
            raise ValueError(f"scenario file {str(path)!r} does not exist")
        return path
    known = list_scenarios()
    if str(name) not in known:
        hint = difflib.get_close_matches(str(name), known, n=1)
        maybe = f" (did you mean {hint[0]!r}?)" if hint else ""
        raise ValueError(
            f"unknown scenario {str(name)!r}{maybe}; known scenarios: {', '.join(known)}"
        )
    for suffix in SCENARIO_SUFFIXES:
        candidate = scenario_dir() / f"{name}{suffix}"
        if candidate.is_file():
            return candidate
    raise AssertionError("listed scenario has no file")  # pragma: no cover


def load_scenario(name: str | Path = "fruits_poisons", **overrides: Any) -> ScenarioSpec:
    """Load, merge and validate a scenario by name or path; raise ``ScenarioError``."""
    raw, marks = read_raw(name)
    if overrides:
        raw = merge(raw, overrides, marks, (), OVERRIDES)
    spec = validate(raw, marks, fallback=str(scenario_path(name)))
    # Imported here: building needs the physics, validation alone does not.
    from flatland_ma.scenario.builder import check_layout

    try:
        check_layout(spec)
    except SpecError as err:
        raise ScenarioError([_problem(marks, err.path, str(err), str(name))]) from None
    return spec


def read_raw(name: str | Path, _chain: tuple[str, ...] = ()) -> tuple[dict, Marks]:
    """Parse a file (following ``extends``) into plain data and the line of every key."""
    path = scenario_path(name)
    source = str(path)
    if source in _chain or len(_chain) > _MAX_EXTENDS:
        raise ScenarioError([Problem(source, None, ("extends",), "extends itself in a cycle")])
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ScenarioError([Problem(source, None, (), f"cannot read the file: {err}")]) from None
    marks: Marks = {}
    raw = parse_yaml(text, source, marks)
    base_name = raw.pop("extends", None)
    if base_name is None:
        return raw, marks
    if not isinstance(base_name, str):
        raise ScenarioError(
            [_problem(marks, ("extends",), "expected the name of a scenario", source)]
        )
    try:
        base, base_marks = read_raw(base_name, _chain + (source,))
    except ValueError as err:
        if isinstance(err, ScenarioError):
            raise
        raise ScenarioError([_problem(marks, ("extends",), str(err), source)]) from None
    del marks[("extends",)]
    return merge(base, raw, base_marks, (), marks), base_marks


def parse_yaml(text: str, source: str, marks: Marks) -> dict:
    """YAML text -> dict, recording the line of every key path into ``marks``."""
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(err, "problem", None) or str(err)
        raise ScenarioError([Problem(source, line, (), f"not valid YAML: {problem}")]) from None
    if node is None:
        return {}
    problems: list[Problem] = []
    data = _node_to_python(node, (), source, marks, problems, yaml.SafeLoader(""), 0)
    if problems:
        raise ScenarioError(problems)
    if not isinstance(data, dict):
        raise ScenarioError(
            [Problem(source, node.start_mark.line + 1, (), "the file must be a mapping of keys")]
        )
    return data


def _node_to_python(node, path, source, marks, problems, constructor, depth):
    marks[path] = (source, node.start_mark.line + 1)
    if depth > _MAX_DEPTH:
        problems.append(Problem(source, node.start_mark.line + 1, path, "nested too deeply"))
        return None
    if isinstance(node, yaml.MappingNode):
        result: dict = {}
        for key_node, value_node in node.value:
            line = key_node.start_mark.line + 1
            if not isinstance(key_node, yaml.ScalarNode) or key_node.tag != "tag:yaml.org,2002:str":
                problems.append(Problem(source, line, path, "keys must be plain words"))
                continue
            key = key_node.value
            if key in result:
                problems.append(Problem(source, line, path + (key,), "key given twice"))
                continue
            result[key] = _node_to_python(
                value_node, path + (key,), source, marks, problems, constructor, depth + 1
            )
            marks[path + (key,)] = (source, line)
        return result
    if isinstance(node, yaml.SequenceNode):
        return [
            _node_to_python(child, path + (i,), source, marks, problems, constructor, depth + 1)
            for i, child in enumerate(node.value)
        ]
    try:
        return constructor.construct_object(node)
    except yaml.YAMLError as err:
        problems.append(Problem(source, node.start_mark.line + 1, path, f"bad value: {err}"))
        return None


def merge(base: dict, top: Mapping, marks: Marks, prefix: KeyPath, top_marks) -> dict:
    """Merge ``top`` over ``base`` (mappings key by key, other values replaced).

    ``marks`` is updated in place: keys taken from ``top`` get ``top_marks`` (a dict of
    marks, or the name of a source without lines such as ``<overrides>``).
    """
    result = dict(base)
    for key, value in top.items():
        path = prefix + (key,)
        if isinstance(value, Mapping) and isinstance(result.get(key), dict):
            _mark(marks, path, top_marks, subtree=False)
            result[key] = merge(result[key], value, marks, path, top_marks)
            continue
        for stale in [p for p in marks if p[: len(path)] == path]:
            del marks[stale]
        _mark(marks, path, top_marks, subtree=True)
        result[key] = _plain(value)
    return result


def _mark(marks: Marks, path: KeyPath, top_marks, subtree: bool) -> None:
    if isinstance(top_marks, str):
        marks[path] = (top_marks, None)
        return
    for p, where in top_marks.items():
        if p == path or (subtree and p[: len(path)] == path):
            marks[p] = where


def _plain(value):
    """Copy override values into the plain dict/list form a file would give."""
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def validate(raw: dict, marks: Marks, fallback: str) -> ScenarioSpec:
    """Validate plain data into a ``ScenarioSpec``; raise ``ScenarioError`` on any fault."""
    try:
        return ScenarioSpec.model_validate(raw)
    except ValidationError as err:
        problems = [_from_pydantic(e, raw, marks, fallback) for e in err.errors()]
        raise ScenarioError(problems) from None


def _from_pydantic(error: dict, raw: dict, marks: Marks, fallback: str) -> Problem:
    loc = tuple(error["loc"])
    cause = (error.get("ctx") or {}).get("error")
    if isinstance(cause, SpecError):
        return _problem(marks, cause.path, str(cause), fallback)
    path = _data_path(loc, raw)
    kind = error["type"]
    given = error.get("input")
    if kind == "extra_forbidden":
        allowed = sorted(_model_at(loc[:-1]).model_fields)
        hint = difflib.get_close_matches(str(loc[-1]), allowed, n=1)
        maybe = f" (did you mean {hint[0]!r}?)" if hint else ""
        message = f"unknown key {loc[-1]!r}{maybe}; allowed keys: {', '.join(allowed)}"
    elif kind == "missing" and isinstance(loc[-1], int):
        message = f"too few items: item [{loc[-1]}] is missing"
    elif kind == "missing":
        message = f"missing required key {loc[-1]!r}"
    else:
        text = error["msg"].removeprefix("Value error, ")
        message = text if kind == "value_error" else f"{text}; got {given!r}"
    return _problem(marks, path, message, fallback)


def _data_path(loc: tuple, raw: Any) -> KeyPath:
    """Drop the parts of a pydantic location that are not keys of the data (union tags)."""
    path: list = []
    node = raw
    for part in loc:
        if isinstance(node, dict) and part in node:
            node = node[part]
            path.append(part)
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
            path.append(part)
        elif isinstance(node, dict) and isinstance(part, str) and not _is_tag(part, node):
            path.append(part)  # a missing or unknown key: report at the key itself
            break
    return tuple(path)


TAG_KEYS = ("shape", "generator")
"""Keys whose value picks the model of a mapping (pydantic puts it in error locations)."""


def _is_tag(part: str, node: dict) -> bool:
    return any(node.get(k) == part for k in TAG_KEYS)


def _model_at(loc: tuple) -> type[BaseModel]:
    """The model class that validates the mapping at ``loc`` (for listing its keys)."""
    model: Any = ScenarioSpec
    for part in loc:
        if isinstance(part, int):
            continue
        fields = getattr(model, "model_fields", {})
        if part in fields:
            model = _inner_model(fields[part].annotation)
        else:  # a discriminator tag: pick the union member whose tag matches
            model = _member_with_tag(model, part) or model
    return model if isinstance(model, type) and issubclass(model, BaseModel) else ScenarioSpec


def _inner_model(annotation: Any) -> Any:
    while True:
        origin = typing.get_origin(annotation)
        args = typing.get_args(annotation)
        if origin is typing.Annotated:
            annotation = args[0]
        elif origin in (tuple, list) and args:
            annotation = args[0]
        else:
            return annotation


def _member_with_tag(union: Any, tag: str) -> Any:
    for member in typing.get_args(union):
        fields = getattr(member, "model_fields", {})
        for name in TAG_KEYS:
            if name in fields and tag in typing.get_args(fields[name].annotation):
                return member
    return None


def _problem(marks: Marks, path: KeyPath, message: str, fallback: str) -> Problem:
    """Locate ``path`` at its own line, or at the nearest enclosing key that has one."""
    for n in range(len(path), -1, -1):
        if path[:n] in marks:
            source, line = marks[path[:n]]
            return Problem(source, line, tuple(path), message)
    return Problem(fallback, None, tuple(path), message)
