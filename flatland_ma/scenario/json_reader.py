"""Strict JSON text into plain data, with the line where every key path was written (as
``yaml_reader`` does for YAML), for the JSON files this package reads from outside.

Strict means what RFC 8259 allows and nothing more: no ``NaN``, ``Infinity`` or
``-Infinity`` tokens (Python's ``json`` reads them by default), no number too large for a
float (``1e999``), no integer longer than ``MAX_DIGITS`` digits, no key given twice.
Nesting is limited to ``MAX_DEPTH`` levels. Every fault is a ``ScenarioError`` naming
the file, the line and, once inside the document, the key path.
"""

from __future__ import annotations

import bisect
import json
import math
import re
from json.scanner import make_scanner
from typing import Any, cast

from flatland_ma.scenario.errors import KeyPath, Marks, Problem, ScenarioError

MAX_DEPTH = 32
"""How deeply objects and arrays may nest."""
MAX_DIGITS = 18
"""The longest integer, in digits (a 64-bit integer has at most 19)."""
_SPACE = re.compile(r"[ \t\n\r]*")


class _Fault(Exception):
    def __init__(self, message: str, at: int, path: KeyPath = ()):
        super().__init__(message)
        self.at, self.path = at, path


def parse_json(text: str, source: str, marks: Marks):
    """Strict JSON ``text`` -> plain data, recording the line of every key path into
    ``marks``; ``ScenarioError`` (file, line, key path) for anything else."""
    reader = _Reader(text, source, marks)
    try:
        value, end = reader.value(0, (), 0)
        end = _SPACE.match(text, end).end()  # type: ignore[union-attr]
        if end != len(text):
            raise _Fault("more after the end of the document", end)
    except _Fault as fault:
        line = reader.line(fault.at)
        raise ScenarioError([Problem(source, line, fault.path, str(fault))]) from None
    return value


class _Reader:
    def __init__(self, text: str, source: str, marks: Marks):
        self.text, self.source, self.marks = text, source, marks
        self.newlines = [m.start() for m in re.finditer("\n", text)]
        decoder = json.JSONDecoder(
            parse_constant=self._constant, parse_int=self._int, parse_float=self._float
        )
        self.scan = make_scanner(cast(Any, decoder))
        """Reads one scalar (string, number, constant) at an index: (value, end)."""
        self.path: KeyPath = ()
        self.at = 0

    def line(self, at: int) -> int:
        return bisect.bisect_left(self.newlines, at) + 1

    def value(self, at: int, path: KeyPath, depth: int):
        text = self.text
        at = _SPACE.match(text, at).end()  # type: ignore[union-attr]
        if at >= len(text):
            raise _Fault("the document ends where a value belongs", at, path)
        self.marks[path] = (self.source, self.line(at))
        if text[at] in "{[":
            if depth >= MAX_DEPTH:
                raise _Fault(f"nested more than {MAX_DEPTH} levels deep", at, path)
            if text[at] == "{":
                return self._object(at + 1, path, depth + 1)
            return self._array(at + 1, path, depth + 1)
        self.path, self.at = path, at
        try:
            return self.scan(text, at)
        except StopIteration:
            raise _Fault(f"not JSON: unexpected {text[at : at + 12]!r}", at, path) from None
        except json.JSONDecodeError as err:  # a string with a bad escape or a control char
            raise _Fault(f"not JSON: {err.msg}", err.pos, path) from None

    def _object(self, at: int, path: KeyPath, depth: int):
        text, result = self.text, {}
        at = _SPACE.match(text, at).end()  # type: ignore[union-attr]
        if text.startswith("}", at):
            return result, at + 1
        while True:
            if not text.startswith('"', at):
                raise _Fault("not JSON: expected a key in double quotes", at, path)
            try:
                key, at = self.scan(text, at)
            except json.JSONDecodeError as err:
                raise _Fault(f"not JSON: {err.msg}", err.pos, path) from None
            if key in result:
                raise _Fault("key given twice", at, path + (key,))
            at = _SPACE.match(text, at).end()  # type: ignore[union-attr]
            if not text.startswith(":", at):
                raise _Fault("not JSON: expected ':' after the key", at, path + (key,))
            result[key], at = self.value(at + 1, path + (key,), depth)
            at = _SPACE.match(text, at).end()  # type: ignore[union-attr]
            if text.startswith("}", at):
                return result, at + 1
            if not text.startswith(",", at):
                raise _Fault("not JSON: expected ',' or '}'", at, path)
            at = _SPACE.match(text, at + 1).end()  # type: ignore[union-attr]

    def _array(self, at: int, path: KeyPath, depth: int):
        text, result = self.text, []
        at = _SPACE.match(text, at).end()  # type: ignore[union-attr]
        if text.startswith("]", at):
            return result, at + 1
        while True:
            item, at = self.value(at, path + (len(result),), depth)
            result.append(item)
            at = _SPACE.match(text, at).end()  # type: ignore[union-attr]
            if text.startswith("]", at):
                return result, at + 1
            if not text.startswith(",", at):
                raise _Fault("not JSON: expected ',' or ']'", at, path)
            at += 1

    # the scalars' hooks: called by the decoder for the value at ``self.at``
    def _constant(self, token: str):
        raise _Fault(f"{token} is not a JSON number (write null for no value)", self.at, self.path)

    def _int(self, token: str) -> int:
        if len(token.lstrip("-")) > MAX_DIGITS:
            message = f"an integer of {len(token.lstrip('-'))} digits (at most {MAX_DIGITS})"
            raise _Fault(message, self.at, self.path)
        return int(token)

    def _float(self, token: str) -> float:
        if len(token) > 64:
            raise _Fault(f"a number written with {len(token)} characters", self.at, self.path)
        value = float(token)
        if not math.isfinite(value):
            raise _Fault(f"{token} is too large for a number", self.at, self.path)
        return value
