"""Kinds of things chosen by name in scenario files (sensors, rules, parts, generators).

Each kind is a class that names itself in its class statement (``class Lidar(Sensor,
kind="lidar")``); the registry of its base class finds it by that name. On the first
lookup the registry imports every module of its package, so a new kind in a new file of
that package needs no import line anywhere else.

Kinds from outside this package (a user's own) join the same registries: their classes
name their kind the same way, and ``flatland_ma.register`` adds the spec that scenario
files are validated with (``flatland_ma.extensions``). A package can also declare them
as entry points in the group ``flatland_ma.extensions``; those are loaded the first time
a name is not found, or every kind is listed (``load_extensions``).
"""

from __future__ import annotations

import importlib
import pkgutil
import warnings
from importlib.metadata import entry_points
from typing import ClassVar

EXTENSION_GROUP = "flatland_ma.extensions"
"""The entry-point group of packages that add kinds: each entry names a function, called
with no argument (it calls ``flatland_ma.register``), or a module, imported."""

_scanned = False
_loaded: dict[str, str] = {}
"""Each extension entry point loaded (``name = value``), with "" if it loaded, else why not."""


def load_extensions(rescan: bool = False) -> dict[str, str]:
    """Load the installed packages' extensions: once per process, or again with ``rescan``
    (for entry points installed since; those loaded before are not loaded twice). Returns,
    per entry point, "" or why it failed to load; a failure is also a warning, and the
    kinds it would have added stay unknown."""
    global _scanned
    if _scanned and not rescan:
        return dict(_loaded)
    _scanned = True
    for point in entry_points(group=EXTENSION_GROUP):
        key = f"{point.name} = {point.value}"
        if key in _loaded:
            continue
        _loaded[key] = ""  # before loading: a module that looks a kind up does not recurse
        try:
            target = point.load()
            if callable(target):
                target()
        except Exception as err:  # a user's package: report it, and go on without it
            _loaded[key] = f"{type(err).__name__}: {err}"
            warnings.warn(
                f"the flatland_ma extension {key!r} failed to load ({_loaded[key]})",
                RuntimeWarning,
                stacklevel=2,
            )
    return dict(_loaded)


def extension_failures() -> str:
    """A sentence naming the extensions that failed to load, or "" if none did."""
    failed = [f"{key} ({why})" for key, why in _loaded.items() if why]
    return f" (extensions that failed to load: {'; '.join(failed)})" if failed else ""


class ExtensionError(TypeError):
    """A kind that breaks its family's protocol (e.g. a part whose ``build`` returns a
    link it did not declare): a fault of the kind's code, named as such, not of a file."""


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
                f"no {self.what} of kind {kind!r}; known kinds: {known}{extension_failures()}"
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
