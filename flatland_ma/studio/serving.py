"""The server's side of the studio's limits (uvicorn), and the addresses it prints.

uvicorn's own concurrency limit counts open connections, idle ones too, and answers
everyone 503 past it: 80 connections that send nothing would lock the token holder out.
So it is not used. Instead a connection that has not sent a whole request head within
``limits.idle_seconds`` is closed (uvicorn closes idle keep-alive connections itself, and
pings WebSockets), requests without the token are refused at once and never counted, and
the app answers at most ``limits.requests`` requests at once (``app.Guard``).
"""

from __future__ import annotations

import asyncio
import socket

from uvicorn.protocols.http.h11_impl import H11Protocol

WILDCARDS = ("0.0.0.0", "::", "")
"""Hosts that mean every address of the machine: no browser can open them."""
UNROUTED = ("192.0.2.1", 9)
"""A TEST-NET address: connecting a UDP socket to it sends nothing, but picks the address
this machine would use to reach the network."""


def idle_closing_protocol(idle_seconds: float) -> type[H11Protocol]:
    """uvicorn's HTTP/1.1 protocol, closing a connection whose first request head has
    not come within ``idle_seconds`` (a WebSocket upgrade stops the clock)."""

    class IdleClosing(H11Protocol):
        _idle: asyncio.TimerHandle | None = None

        def connection_made(self, transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._idle = self.loop.call_later(idle_seconds, self._close_if_idle)

        def _close_if_idle(self) -> None:
            self._idle = None
            if self.cycle is None and not self.transport.is_closing():
                self.transport.close()

        def _stop_clock(self) -> None:
            if self._idle is not None:
                self._idle.cancel()
                self._idle = None

        def handle_websocket_upgrade(self, event) -> None:
            self._stop_clock()
            super().handle_websocket_upgrade(event)

        def connection_lost(self, exc: Exception | None) -> None:
            self._stop_clock()
            super().connection_lost(exc)

    return IdleClosing


def server_options(limits) -> dict:
    """uvicorn's options for a studio with these ``Limits``."""
    return {
        "http": idle_closing_protocol(limits.idle_seconds),
        "ws_max_size": limits.file_bytes + limits.message_bytes,
        "timeout_keep_alive": 5,
        "timeout_graceful_shutdown": 2,
        "log_level": "warning",
    }


def browser_hosts(host: str) -> list[str]:
    """Names a browser can open the studio listening on ``host`` at: the host itself, or
    for a wildcard this machine's network address and name, then the loopback."""
    if host not in WILDCARDS:
        return [host]
    found = []
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.connect(UNROUTED)
            found.append(probe.getsockname()[0])
    except OSError:
        pass
    name = socket.gethostname()
    if name and name not in found:
        found.append(name)
    return [*found, "127.0.0.1"]


def url_of(host: str, port: int, token: str | None) -> str:
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{port}/" + (f"?token={token}" if token else "")
