"""Kinds of things chosen by name in scenario files (sensors, rules, parts, generators).

Each kind is a class that names itself in its class statement (``class Lidar(Sensor,
kind="lidar")``); the registry of its base class finds it by that name. On the first
lookup the registry imports every module of its package, so a new kind in a new file of
that package needs no import line anywhere else.

Kinds from outside this package (a user's own) join the same registries: their classes
name their kind the same way, and ``flatland_ma.register`` adds the spec that scenario
files are validated with (``flatland_ma.scenario.extensions``). A package can also
declare them as entry points (``flatland_ma.kinds.entry_points``); those are loaded the
first time a name is not found, or every kind is listed.
"""

from __future__ import annotations

import importlib
import pkgutil
from typing import ClassVar

from flatland_ma.kinds.entry_points import (
    extension_failures,
    how_kinds_are_added,
    load_extensions,
)


class ExtensionError(TypeError):
    """A fault of a kind's code, named as such (its class, the scenario entry), not as the
    file's nor as flatland_ma's: a class that does not take its spec's keys, a part whose
    ``build`` returns a link it did not declare, a sensor whose reading is not of its
    space's shape and dtype, code of a user's kind that raised while a scenario was
    checked."""


def outside_kinds(root: type) -> list[type]:
    """Every subclass of ``root`` (at any depth) defined outside this package."""
    found, todo = [], list(root.__subclasses__())
    while todo:
        cls = todo.pop()
        todo += cls.__subclasses__()
        if not cls.__module__.startswith("flatland_ma."):
            found.append(cls)
    return found


def describe_kind(cls: type) -> str:
    """How messages name a kind's class: ``the sensor 'compass' (my_world.compass.Compass)``."""
    kinds = getattr(cls, "KINDS", None)
    what = kinds.what if isinstance(kinds, Kinds) else "kind"
    kind = getattr(cls, "kind", None)
    name = f" {kind!r}" if kind else ""
    return f"the {what}{name} ({cls.__module__}.{cls.__qualname__})"


class Kinds(dict):
    """Classes by kind name, from the modules of ``package`` (e.g. ``flatland_ma.sensors``)
    and from extensions."""

    def __init__(self, package: str, what: str):
        super().__init__()
        self.package, self.what = package, what
        self._found = False

    def __getitem__(self, kind: str) -> type:
        if kind not in self:
            self.discover()
        if kind not in self:
            known = ", ".join(sorted(self)) or "none"
            raise KeyError(
                f"no {self.what} of kind {kind!r}; known kinds: {known}"
                f"{extension_failures() or how_kinds_are_added(self.what)}"
            )
        return super().__getitem__(kind)

    def every(self) -> list[type]:
        """Every class of these kinds, sorted by kind name."""
        self.discover()
        return [self[kind] for kind in sorted(self)]

    def discover(self) -> None:
        """Import every module of the package (each class registers itself), once; load
        the extensions that are not loaded yet."""
        if not self._found:
            package = importlib.import_module(self.package)
            for module in pkgutil.iter_modules(package.__path__):
                importlib.import_module(f"{self.package}.{module.name}")
            self._found = True
        load_extensions()


class Kinded:
    """Base of the classes chosen by kind: a subclass that names ``kind="..."`` in its class
    statement joins its family's ``KINDS`` (set by the family's base class)."""

    KINDS: ClassVar[Kinds]
    kind: ClassVar[str]

    def __init_subclass__(cls, kind: str | None = None, **kwargs):
        super().__init_subclass__(**kwargs)
        if kind is not None:
            cls.kind = kind
            cls.KINDS[kind] = cls
