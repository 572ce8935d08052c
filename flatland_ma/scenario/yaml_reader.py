"""YAML text into plain data, with the file and line where every key path was written.

Only what a scenario needs is read: mappings with plain-word keys, lists and plain
scalars. Nesting is limited (deep nesting is reported at its line, not recursed into),
and so is the number of values a file expands to through aliases (``*name``), so no text
can exhaust the stack or the memory.
"""

from __future__ import annotations

import yaml
import yaml.composer

from flatland_ma.scenario.errors import Marks, Problem, ScenarioError

MAX_DEPTH = 32
"""How deeply mappings and lists may nest."""
MAX_VALUES = 100_000
"""How many values (mappings, lists and scalars) a file may expand to, aliases counted."""


class _Loader(yaml.SafeLoader):
    """A safe loader that stops composing nodes nested deeper than ``MAX_DEPTH``."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent, index):
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH + 1:
                raise yaml.composer.ComposerError(
                    None,
                    None,
                    f"nested more than {MAX_DEPTH} levels deep",
                    self.peek_event().start_mark,
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


class _TooMany(Exception):
    """Raised to stop converting once a file expands to more than ``MAX_VALUES`` values."""


def _compose(text: str):
    """The node tree of ``text``: by libyaml when PyYAML has it (several times faster on
    big files), after a pass over its events has checked the nesting (libyaml's composer
    recurses in C, where a deep file would overflow the stack); else in Python."""
    if not yaml.__with_libyaml__:  # pragma: no cover - PyYAML's wheels bundle libyaml
        return yaml.compose(text, Loader=_Loader)
    try:
        return _compose_fast(text)
    except yaml.YAMLError:  # PyYAML's own reader says more about what is wrong, and where
        return yaml.compose(text, Loader=_Loader)


def _compose_fast(text: str):
    depth = 0
    for event in yaml.parse(text, Loader=yaml.CSafeLoader):
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_DEPTH + 1:
                raise yaml.composer.ComposerError(
                    None, None, f"nested more than {MAX_DEPTH} levels deep", event.start_mark
                )
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1
    return yaml.compose(text, Loader=yaml.CSafeLoader)


def parse_yaml(text: str, source: str, marks: Marks) -> dict:
    """YAML text -> dict, recording the line of every key path into ``marks``."""
    try:
        node = _compose(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(err, "problem", None) or str(err)
        raise ScenarioError([Problem(source, line, (), f"not valid YAML: {problem}")]) from None
    except RecursionError:  # only if the interpreter's own limit is lower than ours
        raise ScenarioError(
            [Problem(source, None, (), "not valid YAML: nested too deeply")]
        ) from None
    if node is None:
        return {}
    reader = _Reader(source, marks)
    try:
        data = reader.convert(node, (), 0)
    except _TooMany:
        message = f"the file expands to more than {MAX_VALUES:,} values (through aliases?)"
        too_many = Problem(source, reader.last_line, (), message)
        raise ScenarioError([*reader.problems, too_many]) from None
    if reader.problems:
        raise ScenarioError(reader.problems)
    if not isinstance(data, dict):
        raise ScenarioError(
            [Problem(source, node.start_mark.line + 1, (), "the file must be a mapping of keys")]
        )
    return data


class _Reader:
    """Turns composed nodes into plain data, recording lines and counting values."""

    def __init__(self, source: str, marks: Marks):
        self.source = source
        self.marks = marks
        self.problems: list[Problem] = []
        self.count = 0
        self.last_line: int | None = None
        self.constructor = yaml.SafeLoader("")

    def convert(self, node, path: tuple, depth: int):
        line = node.start_mark.line + 1
        self.count += 1
        self.last_line = line
        if self.count > MAX_VALUES:
            raise _TooMany
        self.marks[path] = (self.source, line)
        if depth > MAX_DEPTH:
            self.problems.append(Problem(self.source, line, path, "nested too deeply"))
            return None
        if isinstance(node, yaml.MappingNode):
            return self._mapping(node, path, depth)
        if isinstance(node, yaml.SequenceNode):
            return [
                self.convert(child, path + (i,), depth + 1) for i, child in enumerate(node.value)
            ]
        try:
            return self.constructor.construct_object(node)
        except Exception as err:  # a scalar its tag cannot read, e.g. ``!!int abc``
            self.problems.append(Problem(self.source, line, path, f"bad value: {err}"))
            return None

    def _mapping(self, node, path: tuple, depth: int) -> dict:
        result: dict = {}
        for key_node, value_node in node.value:
            line = key_node.start_mark.line + 1
            if not isinstance(key_node, yaml.ScalarNode) or key_node.tag != "tag:yaml.org,2002:str":
                self.problems.append(Problem(self.source, line, path, "keys must be plain words"))
                continue
            key = key_node.value
            if key in result:
                self.problems.append(Problem(self.source, line, path + (key,), "key given twice"))
                continue
            result[key] = self.convert(value_node, path + (key,), depth + 1)
            self.marks[path + (key,)] = (self.source, line)
        return result
