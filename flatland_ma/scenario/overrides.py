"""Keyword overrides from Python, held to what a file could say: plain data only.

A file can only hold mappings with word keys, lists, strings, numbers, true/false and
null, nested at most ``MAX_DEPTH`` deep and ``MAX_VALUES`` values in all. Overrides get the
same limits, so an object with surprising conversions, a structure that contains itself
or an array of a billion numbers is refused at its key path before anything reads it.
NumPy numbers and arrays are plain numbers and lists, and tuples lists; anything else is
refused, naming its type.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NoReturn

import numpy as np

from flatland_ma.scenario.errors import KeyPath, Problem, ScenarioError
from flatland_ma.scenario.yaml_reader import MAX_DEPTH, MAX_VALUES

OVERRIDES = "<overrides>"
"""The source named in messages about keyword overrides."""
_SCALARS = (bool, int, float, str, type(None))


def plain_overrides(overrides: Mapping[str, Any]) -> dict:
    """A plain copy of ``overrides``; raise ``ScenarioError`` at the first value that a
    file could not hold."""
    copied = _Copier().copy(dict(overrides), (), 0)
    assert isinstance(copied, dict)  # a mapping copies to a dict
    return copied


class _Copier:
    def __init__(self):
        self.count = 0

    def copy(self, value, path: KeyPath, depth: int):
        self.count += 1
        if self.count > MAX_VALUES:
            _refuse(path, f"the overrides hold more than {MAX_VALUES:,} values, as a file may")
        if depth > MAX_DEPTH:
            _refuse(path, f"nested more than {MAX_DEPTH} levels deep (does it contain itself?)")
        if type(value) in _SCALARS:
            return value
        if isinstance(value, (np.generic, np.ndarray)):
            if value.size > MAX_VALUES:
                _refuse(path, f"an array of {value.size:,} values, more than a file may hold")
            if value.dtype.kind not in "biuf":
                _refuse(path, f"an array of {value.dtype}, not of numbers")
            return self.copy(value.tolist(), path, depth)
        if isinstance(value, Mapping):
            out = {}
            for key, item in value.items():
                if type(key) is not str:
                    _refuse(path, f"keys must be strings, not {type(key).__name__} ({key!r:.40})")
                out[key] = self.copy(item, path + (key,), depth + 1)
            return out
        if isinstance(value, (list, tuple)):
            return [self.copy(item, path + (i,), depth + 1) for i, item in enumerate(value)]
        kind = f"{type(value).__module__}.{type(value).__qualname__}"
        _refuse(
            path,
            f"expected plain data (a mapping, list, string, number, true/false or None), "
            f"got a {kind}; convert it first (e.g. with float(), str() or .tolist())",
        )


def _refuse(path: KeyPath, message: str) -> NoReturn:
    raise ScenarioError([Problem(OVERRIDES, None, path, message)])
