"""Faults of a kind's own code told apart from faults of a scenario file: the builder
makes every sensor, rule, part and generator through ``make_kind``, and a class from
outside this package (a user's kind) that fails there is named as the culprit."""

from __future__ import annotations

from collections.abc import Callable

from flatland_ma.kinds.registry import ExtensionError, Kinded, describe_kind, outside_kinds
from flatland_ma.scenario.errors import ScenarioError, SpecError


def make_kind(cls: type, where: str, values: dict, make: Callable, *args, **kwargs):
    """``make(*args, **kwargs)``, which makes an instance of ``cls`` from a scenario
    entry's ``values`` (``cls`` itself, or its ``from_spec``), with a fault of a class from
    outside this package (a user's kind) reported as its own: an ``ExtensionError``
    naming the class, the entry (``where``) and its keys."""
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
    packages = {cls.__module__.split(".")[0] for cls in outside_kinds(Kinded)}
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
