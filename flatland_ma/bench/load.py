"""What else the machine did while a benchmark row ran: the CPU that other processes used.

A rate measured while another process held a core says little about the code, so each row
of ``flatland-ma bench`` carries the cores that processes outside the benchmark's own
process tree kept busy during it (from ``/proc/stat`` less this tree's CPU time), and the
load average at its end; ``BUSY_CORES`` or more flags the row as taken on a busy machine.
Outside Linux only the load average is known.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

BUSY_CORES = 0.25
"""Cores used by other processes above which a row is flagged: a quarter of a core."""
PROC = Path("/proc")


def _machine_busy_seconds() -> float | None:
    """CPU seconds every core has spent busy since boot (all but idle and iowait)."""
    try:
        fields = (PROC / "stat").read_text().split("\n", 1)[0].split()[1:]
        ticks = [int(f) for f in fields]
    except (OSError, ValueError):
        return None
    idle = ticks[3] + (ticks[4] if len(ticks) > 4 else 0)
    return (sum(ticks[:8]) - idle) / os.sysconf("SC_CLK_TCK")


def _tree_seconds(root: int) -> float:
    """CPU seconds used so far by ``root`` and every live process below it (plus the
    children they have reaped)."""
    parents: dict[int, int] = {}
    seconds: dict[int, float] = {}
    tick = os.sysconf("SC_CLK_TCK")
    for entry in PROC.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        rest = stat[stat.rindex(")") + 2 :].split()
        pid = int(entry.name)
        parents[pid] = int(rest[1])
        seconds[pid] = sum(int(x) for x in rest[11:15]) / tick  # utime stime cutime cstime
    total = 0.0
    for pid, used in seconds.items():
        ancestor, hops = pid, 0
        while ancestor not in (0, 1, root) and hops < 64:
            ancestor, hops = parents.get(ancestor, 0), hops + 1
        if ancestor == root:
            total += used
    return total


@dataclass(frozen=True)
class Load:
    """The machine's state during a row."""

    other_cores: float | None
    """Cores kept busy by processes outside the benchmark (None: not known here)."""
    load_average: float
    """The one-minute load average at the row's end."""
    cores: int
    """The cores this process may use."""

    @property
    def busy(self) -> bool:
        return self.other_cores is not None and self.other_cores >= BUSY_CORES

    def note(self) -> str:
        others = "?" if self.other_cores is None else f"{self.other_cores:.2f}"
        flag = "  BUSY" if self.busy else ""
        return f"others {others} of {self.cores} cores, load {self.load_average:.1f}{flag}"


class LoadMeter:
    """``start()`` before a row, ``stop()`` after it: the ``Load`` in between."""

    def __init__(self, cores: int):
        self.cores = cores
        self._start: tuple[float, float | None, float] | None = None

    def start(self) -> None:
        busy = _machine_busy_seconds()
        ours = _tree_seconds(os.getpid()) if busy is not None else 0.0
        self._start = (time.perf_counter(), busy, ours)

    def stop(self) -> Load:
        assert self._start is not None, "start() first"
        began, busy, ours = self._start
        wall = time.perf_counter() - began
        now = _machine_busy_seconds()
        others = None
        if busy is not None and now is not None and wall > 0:
            mine = _tree_seconds(os.getpid()) - ours
            others = max(0.0, (now - busy - mine) / wall)
        return Load(others, os.getloadavg()[0], self.cores)
