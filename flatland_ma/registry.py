"""Kinds of things chosen by name in scenario files (sensors, rules, parts, generators).

Each kind is a class that names itself in its class statement (``class Lidar(Sensor,
kind="lidar")``); the registry of its base class finds it by that name. On the first
lookup the registry imports every module of its package, so a new kind in a new file of
that package needs no import line anywhere else.
"""

from __future__ import annotations

import importlib
import pkgutil
from typing import ClassVar


class Kinds(dict):
    """Classes by kind name, from the modules of ``package`` (e.g. ``flatland_ma.sensors``)."""

    def __init__(self, package: str, what: str):
        super().__init__()
        self.package, self.what = package, what
        self._found = False

    def __getitem__(self, kind: str) -> type:
        if kind not in self and not self._found:
            self.discover()
        if kind not in self:
            known = ", ".join(sorted(self)) or "none"
            raise KeyError(f"no {self.what} of kind {kind!r}; known kinds: {known}")
        return super().__getitem__(kind)

    def every(self) -> list[type]:
        """Every class of the package's kinds, sorted by kind name."""
        if not self._found:
            self.discover()
        return [self[kind] for kind in sorted(self)]

    def discover(self) -> None:
        """Import every module of the package (each class registers itself)."""
        package = importlib.import_module(self.package)
        for module in pkgutil.iter_modules(package.__path__):
            importlib.import_module(f"{self.package}.{module.name}")
        self._found = True


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
