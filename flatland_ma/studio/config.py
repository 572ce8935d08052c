"""What a studio may touch and how much it may do at once."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

MAX_SEED = 2**32 - 1
"""Seeds run from 0 to this (NumPy's legacy range; every generator here accepts it): the
studio's requests and the command line's options (``flatland_ma.cli.options``) alike."""
LOOPBACK = ("127.0.0.1", "localhost", "::1")
"""Addresses reachable from this machine only: bound to one, the studio asks no token."""


@dataclass(frozen=True)
class Limits:
    """Bounds on what clients may ask for (each one refused with a message past it)."""

    episodes: int = 8
    """Episodes (watch or play WebSockets) running at once."""
    fps: float = 30.0
    """Frames a second an episode sends at most."""
    request_bytes: int = 512 * 1024
    """An HTTP request's body (a scenario's YAML text travels in one)."""
    message_bytes: int = 4096
    """A WebSocket message from a client."""
    file_bytes: int = 512 * 1024
    """A scenario file read from or written to a folder."""
    recorded_frames: int = 300
    """Frames kept per episode for its GIF (the latest ones, as sent: 20-60 kB each)."""
    work: int = 2
    """Heavy jobs at once (each takes a thread): the editor's checks and previews, and
    the GIFs; the pages' reads (gallery, pictures, info) have as many threads of their
    own, so they never wait behind heavy jobs."""
    pictures: int = 256
    """Gallery pictures kept in memory."""
    requests: int = 64
    """Requests (with the token, when there is one) answered at once; one more is told
    503. Requests without the token are refused at once and never counted."""
    idle_seconds: float = 15.0
    """A connection that has not sent a whole request after this long is closed; an
    episode's page that has sent nothing for ``idle_episode_seconds`` loses its episode."""
    idle_episode_seconds: float = 120.0
    """See ``idle_seconds``: the pages say they are there every 20 seconds."""
    clients: int = 256
    """Clients whose heavy jobs are queued (one at a time each) that are remembered."""
    gif_width: int = 480
    """A GIF's frames are scaled down to at most this width."""
    gifs: int = 16
    """GIFs being made or kept for download at once (the oldest is dropped past it)."""


@dataclass(frozen=True)
class StudioConfig:
    """``folders``: where scenario files are listed, read and saved; ``checkpoints``: the
    folder of checkpoint files policies may load; ``token``: what every request must carry
    (None when bound to the loopback); ``scores``: the CSV each played episode's rows are
    appended to (None: not written)."""

    folders: tuple[Path, ...] = ()
    checkpoints: Path | None = None
    token: str | None = None
    scores: Path | None = None
    limits: Limits = field(default_factory=Limits)
