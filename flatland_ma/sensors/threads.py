"""How many of numba's threads the ray kernel uses, and when it uses them at all.

A machine's core count says little about the cores this process may have: its CPU
affinity (``taskset``, a cluster's job slot) and its cgroup's quota (a container) may give
it fewer, and other processes may hold some of those. A parallel region waits for its
slowest thread, so a thread that has no core to run on stalls every step of the batched
env: on a 2-core machine with one core held by another process, 16 worlds cast over two
threads ran at a sixth of their one-thread rate. Three things keep that from happening:

- ``usable_cpus`` counts the CPUs this process may use (affinity and cgroup quota), and
  ``fit_threads`` caps numba's thread count to it, unless ``NUMBA_NUM_THREADS`` was set;
- OpenMP's idle threads sleep instead of spinning (``OMP_WAIT_POLICY=PASSIVE`` unless the
  user chose otherwise), so a waiting thread gives its core back. OpenMP reads it once,
  when it starts, and torch shares it: spinning threads left by the ray kernel made
  torch's convolutions in the same process about 50 times slower. Importing
  ``flatland_ma`` sets it; a program that imports torch first should set it itself;
- ``Chooser`` times the parallel and the one-thread kernel as they run and keeps the faster,
  trying the other again now and then (less often each time it loses), so a batch falls
  back to one thread while the machine is busy and spreads out again when it is not. Both
  paths compute exactly the same results; only the speed depends on the choice.
"""

from __future__ import annotations

import ctypes
import math
import os
import time
import warnings
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path


def cgroup_cpus(root: Path = Path("/sys/fs/cgroup")) -> float | None:
    """The CPU quota of this process's cgroup, in CPUs (cgroup v2 ``cpu.max`` or v1
    ``cpu.cfs_quota_us``), or None when there is none."""
    try:
        quota, period = (root / "cpu.max").read_text().split()[:2]
        return None if quota == "max" else int(quota) / int(period)
    except (OSError, ValueError):
        pass
    try:
        quota = int((root / "cpu" / "cpu.cfs_quota_us").read_text())
        period = int((root / "cpu" / "cpu.cfs_period_us").read_text())
        return None if quota <= 0 or period <= 0 else quota / period
    except (OSError, ValueError):
        return None


def usable_cpus() -> int:
    """The CPUs this process may use: its affinity, capped by its cgroup's quota."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    quota = cgroup_cpus()
    if quota is not None:
        cpus = min(cpus, max(1, math.ceil(quota)))
    return max(1, cpus)


def openmp() -> ctypes.CDLL | None:
    """The OpenMP runtime already loaded in this process (GNU's ``libgomp``, which numba's
    OpenMP pool and torch share), or None."""
    try:
        return ctypes.CDLL("libgomp.so.1", mode=os.RTLD_NOLOAD | os.RTLD_GLOBAL)
    except OSError:
        return None


@contextmanager
def openmp_threads_kept():
    """Leave OpenMP's thread count (its ``nthreads`` setting, which
    ``torch.get_num_threads`` reads and ``torch.set_num_threads`` writes) as it was on
    entry. Starting numba's OpenMP pool, or setting numba's thread count, sets OpenMP's too:
    with one ``libgomp`` in the process, a learner that asked torch for one thread got
    numba's count, two, from the first parallel ray kernel on. numba itself keeps its count
    per thread and passes it with each launch, so it is unaffected."""
    runtime = openmp()
    before = runtime.omp_get_max_threads() if runtime is not None else None
    try:
        yield
    finally:
        if runtime is not None and before is not None:
            runtime.omp_set_num_threads(before)


def fit_threads() -> int:
    """Cap numba's threads to the usable CPUs (unless ``NUMBA_NUM_THREADS`` says how
    many) and return the count in force, starting numba's pool without changing the
    thread count of OpenMP's other users (``openmp_threads_kept``)."""
    import numba

    with openmp_threads_kept():
        if "NUMBA_NUM_THREADS" not in os.environ:
            wanted = min(numba.config.NUMBA_NUM_THREADS, usable_cpus())  # type: ignore[attr-defined]
            if numba.get_num_threads() != wanted:
                numba.set_num_threads(wanted)
        return numba.get_num_threads()


def openmp_spins() -> bool:
    """Whether OpenMP was started before ``flatland_ma`` could ask its idle threads to
    sleep: a runtime already loaded when the package was imported, with no
    ``OMP_WAIT_POLICY`` in the environment then. Its threads then spin after every
    parallel region (torch's and the ray kernel's alike), and on a machine with few cores
    a learner runs several times slower (SB3 on the batched env: 8x)."""
    return STARTED_BEFORE_US


STARTED_BEFORE_US = "OMP_WAIT_POLICY" not in os.environ and openmp() is not None
"""Set when this module is first imported (``flatland_ma`` imports it first): see
``openmp_spins``."""
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
SPINNING_WARNING = (
    "OpenMP (loaded by torch or another library imported before flatland_ma) was started "
    "without OMP_WAIT_POLICY, so its idle threads spin and a learner on flatland_ma can run "
    "several times slower on a machine with few cores. Import flatland_ma before torch, or "
    "set OMP_WAIT_POLICY=PASSIVE in the environment before Python starts."
)
if STARTED_BEFORE_US:
    warnings.warn(SPINNING_WARNING, RuntimeWarning, stacklevel=2)


class Chooser:
    """Runs the faster of a parallel and a one-thread version of the same call.

    The chosen version's cost is an average of its recent calls. After ``patience``
    calls the other version is tried for ``TRIAL`` calls, and their median is its cost;
    if it is cheaper it is chosen, and if not ``patience`` doubles (up to
    ``MAX_PATIENCE``), so that a version which stalls (a thread with no core) costs a
    few percent at most. A one-thread machine never tries the parallel one.
    """

    FIRST_PATIENCE = 64
    MAX_PATIENCE = 4096
    TRIAL = 4
    WEIGHT = 0.1
    """How much one call moves the chosen version's average cost."""

    def __init__(
        self,
        parallel: Callable,
        serial: Callable,
        threads: int,
        clock: Callable[[], float] = time.perf_counter,
    ):
        self.clock = clock
        self.versions = (serial, parallel) if threads > 1 else (serial,)
        self.chosen = len(self.versions) - 1
        self.cost = math.nan
        """The chosen version's average cost per call, in seconds."""
        self.patience = self.FIRST_PATIENCE
        self.calls = 0
        self.trial: list[float] = []

    @property
    def parallel(self) -> bool:
        """Whether the parallel version is the one chosen now."""
        return self.chosen == 1

    def __call__(self, *args) -> None:
        trying = len(self.versions) > 1 and self.calls >= self.patience
        k = 1 - self.chosen if trying else self.chosen
        start = self.clock()
        self.versions[k](*args)
        cost = self.clock() - start
        if not trying:
            self.calls += 1
            self.cost = (
                cost if math.isnan(self.cost) else self.cost + self.WEIGHT * (cost - self.cost)
            )
            return
        self.trial.append(cost)
        if len(self.trial) < self.TRIAL:
            return
        other = sorted(self.trial)[len(self.trial) // 2]
        self.trial, self.calls = [], 0
        if other < self.cost:
            self.chosen, self.cost, self.patience = k, other, self.FIRST_PATIENCE
        else:
            self.patience = min(2 * self.patience, self.MAX_PATIENCE)
