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
from collections.abc import Callable
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


def how_kinds_are_added(what: str) -> str:
    """The end of a message about an unknown kind: how a kind joins (its package
    installed with an entry point, or registered by a call before the file is loaded)."""
    return (
        f". A {what} from another package is known once that package is installed in this "
        f"environment with an entry point in the group {EXTENSION_GROUP!r}, or after "
        "flatland_ma.register(spec, class) runs in this process (see the docs' Extending "
        "guide)"
    )


def extension_failures() -> str:
    """A sentence naming the extensions that failed to load, or "" if none did."""
    failed = [f"{key} ({why})" for key, why in _loaded.items() if why]
    return f" (extensions that failed to load: {'; '.join(failed)})" if failed else ""


class ExtensionError(TypeError):
    """A fault of a kind's code, named as such (its class, the scenario entry), not as the
    file's nor as flatland_ma's: a class that does not take its spec's keys, a part whose
    ``build`` returns a link it did not declare, a sensor whose reading is not of its
    space's shape and dtype, code of a user's kind that raised while a scenario was
    checked."""


def _outside_kinds(root: type) -> list[type]:
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


def make_kind(cls: type, where: str, values: dict, make: Callable, *args, **kwargs):
    """``make(*args, **kwargs)``, which makes an instance of ``cls`` from a scenario
    entry's ``values`` (``cls`` itself, or its ``from_spec``), with a fault of a class from
    outside this package (a user's kind) reported as its own: an ``ExtensionError``
    naming the class, the entry (``where``) and its keys."""
    from flatland_ma.scenario.errors import ScenarioError, SpecError

    try:
        return make(*args, **kwargs)
    except (SpecError, ScenarioError):
        raise  # a located fault the kind found in its entry: the file's, as it says
    except Exception as err:
        if cls.__module__.startswith("flatland_ma."):
            raise
        keys = ", ".join(sorted(values)) or "none"
        hint = ""
        if isinstance(err, TypeError) and ("argument" in str(err) or "keyword" in str(err)):
            hint = (
                "; the builder passes each key of the entry's spec as a keyword argument "
                "(from_spec's default is cls(**values)): accept every key of the spec, or "
                "override the class's from_spec"
            )
        raise ExtensionError(
            f"{where}: {describe_kind(cls)} could not be made from its entry's keys ({keys}):"
            f" {type(err).__name__}: {err}{hint}. This is a fault of that class or its spec,"
            " not of flatland_ma"
        ) from err


def made_from_spec(made, base: type, cls: type, where: str):
    """``made``, which ``cls.from_spec`` returned for the entry at ``where``, if it is a
    ``base`` (a ``Part``, a ``Sensor``); else an ``ExtensionError`` naming the class."""
    if not isinstance(made, base):
        raise ExtensionError(
            f"{where}: {describe_kind(cls)}.from_spec returned {made!r:.80}, not a {base.__name__}"
        )
    return made


def fault_in_extension(err: BaseException) -> str | None:
    """Where in a user's kind ``err`` was raised (its innermost frame in a package that
    defines a kind registered from outside this one), as ``module.function (file, line
    N)``; None if it was not raised in such code."""
    packages = {cls.__module__.split(".")[0] for cls in _outside_kinds(Kinded)}
    packages.discard("flatland_ma")
    found = None
    tb = err.__traceback__
    while tb is not None:
        module = tb.tb_frame.f_globals.get("__name__", "")
        if module.split(".")[0] in packages:
            code = tb.tb_frame.f_code
            name = getattr(code, "co_qualname", code.co_name)
            found = f"{module}.{name} ({code.co_filename}, line {tb.tb_lineno})"
        tb = tb.tb_next
    return found


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
