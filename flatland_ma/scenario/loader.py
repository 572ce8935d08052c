"""Reading scenario files into a validated ``ScenarioSpec``.

A file is YAML. ``extends: NAME`` at its top starts from another scenario and merges this
file's keys over it. Keyword overrides from Python are merged last. Mappings merge key by
key; any other value (lists included) replaces what was there. Every fault is reported
with the file, the line and the key path it concerns.
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from flatland_ma.scenario.errors import (
    KeyPath,
    Marks,
    Problem,
    ScenarioError,
    UnknownKeywordError,
    locate,
)
from flatland_ma.scenario.files import check_regular_file, read_text
from flatland_ma.scenario.messages import problems_from
from flatland_ma.scenario.overrides import OVERRIDES, plain_overrides
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.scenario.shipped import SCENARIO_SUFFIXES, list_scenarios, scenario_dir
from flatland_ma.scenario.shipped import list_streams as list_streams  # importable from here
from flatland_ma.scenario.shipped import stream_dir as stream_dir  # too, as before
from flatland_ma.scenario.yaml_reader import parse_yaml

SCHEMA_FILE = "scenario.schema.json"
"""The JSON schema of scenario files (for editors), shipped beside the scenarios."""
_MAX_EXTENDS = 8


def schema_path() -> Path:
    """The shipped JSON schema of scenario files, for editors' completion and checks."""
    return scenario_dir() / SCHEMA_FILE


def scenario_path(name: str | Path) -> Path:
    """The file of a shipped scenario, or ``name`` itself if it is a path to a file."""
    path = Path(name)
    if path.suffix in SCENARIO_SUFFIXES or path.is_file():
        if not path.is_file():
            if os.path.lexists(path):  # a folder, a FIFO, a device, a loop of links...
                check_regular_file(path)
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
    """Load, merge and validate a scenario by name or path; raise ``ScenarioError``
    (``UnknownKeywordError``, also a ``TypeError``, for an override that is no top-level key).

    This checks the file alone and builds nothing; the checks that need a layout built
    (room to place things, reachability, parts against walls) are ``build.check_scenario``,
    which the envs and ``flatland-ma validate`` run.

    Any other exception met on the way is a bug of this package; it is still reported as a
    ``ScenarioError`` naming the file (with the original exception chained as its cause).
    """
    source = str(scenario_path(name))
    try:
        return _load(name, overrides, source)
    except ScenarioError:
        raise
    except Exception as err:
        message = f"internal error while loading ({type(err).__name__}: {err}); please report it"
        raise ScenarioError([Problem(source, None, (), message)]) from err


def _load(name: str | Path, overrides: dict, source: str) -> ScenarioSpec:
    check_keywords(overrides, source)
    plain = plain_overrides(overrides)
    raw, marks = read_raw(name)
    if plain:
        raw = merge(raw, plain, marks, (), OVERRIDES)
    spec = validate(raw, marks, fallback=source)
    spec.read_from(source, marks)
    return spec


def check_keywords(overrides: Mapping, source: str) -> None:
    """Raise ``UnknownKeywordError`` for override keywords that are no top-level key of a
    scenario, naming each and the scenario file (nested keys are checked by validation)."""
    allowed = sorted(ScenarioSpec.model_fields)
    problems = []
    for key in overrides:
        if key in ScenarioSpec.model_fields:
            continue
        hint = difflib.get_close_matches(str(key), allowed, n=1)
        maybe = f" (did you mean {hint[0]!r}?)" if hint else ""
        # "unexpected keyword argument" as Python says it: clients that probe for optional
        # keywords (TorchRL's GymEnv and frameskip) match those words.
        message = (
            f"unexpected keyword argument {key!r}: no key of a scenario, in the keyword "
            f"overrides of {source}{maybe}; allowed keys: {', '.join(allowed)}"
        )
        problems.append(Problem(OVERRIDES, None, (key,), message))
    if problems:
        raise UnknownKeywordError(problems)


def file_text(path: Path) -> str:
    """The text of a file of this package's formats (scenarios, suites, streams), read
    through ``files.read_text``: a regular file only, within the size limit, UTF-8;
    ``ScenarioError`` naming the file (and the line of a byte that is not UTF-8)."""
    return read_text(path)


def read_raw(name: str | Path, _chain: tuple[str, ...] = ()) -> tuple[dict, Marks]:
    """Parse a file (following ``extends``) into plain data and the line of every key."""
    path = scenario_path(name)
    source = str(path)
    text = file_text(path)
    marks: Marks = {}
    raw = parse_yaml(text, source, marks)
    base_name = raw.pop("extends", None)
    if base_name is None:
        return raw, marks

    def fault(message: str) -> ScenarioError:
        return ScenarioError([locate(marks, ("extends",), message, source)])

    if not isinstance(base_name, str):
        raise fault("expected the name of a scenario")
    try:
        base_path = _base_path(base_name, path)
    except ValueError as err:
        raise fault(str(err)) from None
    chain = _chain + (str(path.resolve()),)
    if str(base_path.resolve()) in chain:
        raise fault(f"extends {base_name!r}, which leads back to this file: a cycle")
    if len(chain) > _MAX_EXTENDS:
        raise fault(f"a chain of more than {_MAX_EXTENDS} files extending one another")
    base, base_marks = read_raw(base_path, chain)
    del marks[("extends",)]
    return merge(base, raw, base_marks, (), marks), base_marks


def _base_path(name: str, extending: Path) -> Path:
    """The file ``extends: name`` names: a path is read from the extending file's folder
    when there is such a file there (else as given), a bare name is a shipped scenario."""
    beside = extending.parent / name
    if name and beside.is_file():
        return beside
    return scenario_path(name)


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
        result[key] = value
    return result


def _mark(marks: Marks, path: KeyPath, top_marks, subtree: bool) -> None:
    if isinstance(top_marks, str):
        marks[path] = (top_marks, None)
        return
    for p, where in top_marks.items():
        if p == path or (subtree and p[: len(path)] == path):
            marks[p] = where


def validate(raw: dict, marks: Marks, fallback: str) -> ScenarioSpec:
    """Validate plain data into a ``ScenarioSpec``; raise ``ScenarioError`` on any fault."""
    try:
        return ScenarioSpec.model_validate(raw)
    except ValidationError as err:
        raise ScenarioError(
            problems_from(err.errors(), ScenarioSpec, raw, marks, fallback)
        ) from None
