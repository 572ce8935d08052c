"""The entry points through which installed packages add kinds (``EXTENSION_GROUP``),
loaded once per process, and the words that tell a user how a kind joins.
"""

from __future__ import annotations

import warnings
from importlib.metadata import entry_points

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
