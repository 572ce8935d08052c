"""Playing a scenario at the keyboard (``flatland-ma play``).

``keys`` maps keys to actions (its docstring has the table) and reads them from the
keyboard or a script; ``session`` plays the game (the other agents' policies, Tab, the
scores file); ``screen`` draws the window's frames. ``play`` ties them to a pygame
window. Everything but the window is plain Python, so tests drive it headless
(``SDL_VIDEODRIVER=dummy``) with posted events or a key script.
"""

from __future__ import annotations

import math
import secrets
from pathlib import Path

from flatland_ma.play.keys import KeyMap, Keys, PygameKeys, ScriptedKeys
from flatland_ma.play.session import OTHERS, SCORE_COLUMNS, Session
from flatland_ma.render import display

__all__ = [
    "OTHERS",
    "SCORE_COLUMNS",
    "KeyMap",
    "Keys",
    "PygameKeys",
    "ScriptedKeys",
    "Session",
    "missing_display",
    "play",
]


def missing_display() -> str | None:
    """Why ``flatland-ma play`` can open no window here, or None if it can
    (``flatland_ma.render.display``)."""
    if display.missing_display() is None:
        return None
    return (
        "flatland-ma play needs a display, and there is none here (DISPLAY and "
        "WAYLAND_DISPLAY are unset). Run it in a desktop session, or with "
        "SDL_VIDEODRIVER=dummy and --keys for a window nobody sees."
    )


def play(
    scenario: str | Path,
    *,
    seed: int | None = None,
    others: str | None = None,
    episodes: int = 1,
    scores: str | Path | None = "play_scores.csv",
    fps: float = 30.0,
    script: str | None = None,
    screenshot: str | Path | None = None,
    overrides: dict | None = None,
) -> Session:
    """Play ``episodes`` episodes in a window; return the session (its ``finished`` rows
    are those appended to ``scores``). Keys come from the keyboard, or from ``script``
    (see ``ScriptedKeys``). ``seed``: the first episode's (drawn at random if None, and
    written with the scores); ``screenshot``: a PNG of the window's last picture;
    ``others``: the policy of the agents you do not drive (None: each its own,
    ``policies.named.default_policy``).
    ``ValueError``, before any window opens, for a bad ``fps``, ``episodes`` or script."""
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and fps >= 0):
        raise ValueError(f"fps must be a finite number, 0 or more (0: no wait), not {fps!r}")
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"episodes must be a whole number, 1 or more, not {episodes!r}")
    source = ScriptedKeys(script) if script is not None else PygameKeys()
    from flatland_ma.envs.parallel import FlatlandParallelEnv
    from flatland_ma.play.screen import Screen
    from flatland_ma.render.video import save_png
    from flatland_ma.render.window import Window

    env = FlatlandParallelEnv(scenario, **(overrides or {}))
    seed = secrets.randbelow(2**31) if seed is None else seed
    path = Path(scores) if scores is not None else None
    session = Session(env, str(scenario), seed, others, episodes, path)
    screen = Screen(session)
    window = Window(screen.size, screen.title())
    try:
        while True:
            if session.changed:
                window.draw(screen.frame())
                window.title(screen.title())
                session.changed = False
            events = window.events()
            if window.closed_by_user:
                session.stopped = True
                break
            if not session.advance(source.poll(events)):
                break
            window.tick(fps)
        if session.changed:
            window.draw(screen.frame())
        if screenshot is not None:
            save_png(window.picture(), screenshot)
    finally:
        window.close()
        env.close()
    return session
