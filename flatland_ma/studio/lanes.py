"""Heavy work (the editor's checks and previews) kept apart from the pages' reads: one job
at a time per client, and a client's newer request replaces its older one still waiting.

An editor sends a check on every edit, and a heavy scenario's check can take seconds:
without this, the jobs of one typing burst would queue up and every other page would wait
behind them. Each client (the ``X-Studio-Client`` header the pages send, else its
address) has a lane: its running job finishes (a thread cannot be stopped), the newest
request waits for it, and any request that was waiting before is answered at once as
superseded (409); a request whose client has left by its turn does not run either. Heavy
jobs of all clients share ``limits.work`` threads; the reads have their own (``Api``).
Lanes are remembered for ``limits.clients`` clients, the least recently seen forgotten
first (an idle lane holds nothing).
"""

from __future__ import annotations

import asyncio
import collections
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

import anyio

CLIENT_HEADER = "x-studio-client"
MAX_CLIENT_ID = 64


class Superseded(Exception):
    """A job that a newer request of the same client replaced before it ran."""


@dataclass
class _Ticket:
    superseded: bool = False


@dataclass
class _Lane:
    busy: bool = False
    waiting: _Ticket | None = None
    changed: asyncio.Condition = field(default_factory=asyncio.Condition)


class Lanes:
    """Per-client lanes over one pool of ``threads`` threads."""

    def __init__(self, threads: int, clients: int):
        self.limiter = anyio.CapacityLimiter(threads)
        self.clients = clients
        self._lanes: collections.OrderedDict[str, _Lane] = collections.OrderedDict()
        self.ran = 0
        """Jobs run to their end (for tests and measurements)."""
        self.superseded = 0
        """Requests answered as superseded without running."""

    def _lane(self, client: str) -> _Lane:
        lane = self._lanes.get(client)
        if lane is None:
            lane = self._lanes[client] = _Lane()
            for key in list(self._lanes):  # forget idle lanes past the bound
                if len(self._lanes) <= self.clients:
                    break
                old = self._lanes[key]
                if not old.busy and old.waiting is None:
                    del self._lanes[key]
        self._lanes.move_to_end(client)
        return lane

    def __len__(self) -> int:
        return len(self._lanes)

    async def run(
        self,
        client: str,
        function: Callable[..., Any],
        *args,
        wanted: Callable[[], Awaitable[bool]] | None = None,
    ) -> Any:
        """``function(*args)`` in a worker thread once ``client``'s lane is free;
        ``Superseded`` if a newer request of the client came first, or if ``wanted()``
        says, when its turn comes, that nobody waits for it any more."""
        lane = self._lane(client)
        mine = _Ticket()
        async with lane.changed:
            if lane.waiting is not None:
                lane.waiting.superseded = True
            lane.waiting = mine
            lane.changed.notify_all()
            await lane.changed.wait_for(lambda: mine.superseded or not lane.busy)
            if mine.superseded:
                self.superseded += 1
                raise Superseded()
            lane.busy, lane.waiting = True, None
        try:
            if wanted is not None and not await wanted():
                self.superseded += 1
                raise Superseded()
            result = await anyio.to_thread.run_sync(function, *args, limiter=self.limiter)
            self.ran += 1
            return result
        finally:
            async with lane.changed:
                lane.busy = False
                lane.changed.notify_all()


def client_of(headers, address: tuple | None) -> str:
    """The client a request comes from: the pages' own id, else its address."""
    given = headers.get(CLIENT_HEADER, "")
    if given and len(given) <= MAX_CLIENT_ID and given.isascii() and given.isprintable():
        return "id:" + given
    return "at:" + (str(address[0]) if address else "?")
