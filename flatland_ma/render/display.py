"""Whether a window can be shown here. No pygame import: asked before a window opens.

On Linux and the like a window needs an X11 or Wayland display (``DISPLAY``,
``WAYLAND_DISPLAY``); without one SDL falls back to drawing nowhere, with a note on
stderr, and the caller would never know. SDL's drivers that need no display (``dummy``,
``offscreen``) are a choice: a window nobody sees, for scripts and tests.
"""

from __future__ import annotations

import os
import sys

HEADLESS_DRIVERS = ("dummy", "offscreen")
"""SDL video drivers that need no display (the window exists but nobody sees it)."""


def missing_display() -> str | None:
    """Why no window can be seen here (a sentence), or None if one can."""
    if os.environ.get("SDL_VIDEODRIVER", "").lower() in HEADLESS_DRIVERS:
        return None
    if sys.platform in ("darwin", "win32"):
        return None
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return None
    return "there is no display here (DISPLAY and WAYLAND_DISPLAY are unset)"


class NoDisplayError(RuntimeError):
    """A window was asked for where none can be seen."""


def no_window(why: str | None) -> None:
    """Raise ``NoDisplayError`` for ``render_mode="human"`` if ``why`` (from
    ``missing_display``) says no window can be seen here."""
    if why is not None:
        raise NoDisplayError(
            f'render_mode="human" shows a window, and {why}. Use render_mode="rgb_array" for '
            "frames as arrays (flatland-ma record writes videos), run in a desktop session, "
            "or set SDL_VIDEODRIVER=dummy for a window nobody sees."
        )
