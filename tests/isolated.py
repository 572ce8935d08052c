"""Running one scenario case in a process of its own, with a time and a memory limit.

A case is a scenario (a file path or a shipped name) and keyword overrides. It is loaded
with ``flatland_ma.parallel_env``; if it loads, the env is reset with two seeds and
stepped with random actions, and every observation is checked to be finite and inside
the observation space. Whatever the case does (hang, exhaust the memory, abort in C), the
test that runs it gets an ``Outcome`` back and the test run goes on.

Starting Python and importing the package and its compiled kernels takes seconds, too
long to pay per case. So one *zygote* process per test process imports everything and
warms up once (it builds and steps a few envs, which loads the kernels), then serves
requests: for each it forks a child, which limits its own address space and CPU time and
runs the case, and reports a JSON outcome through a pipe. A case's time limit is CPU
time (``RLIMIT_CPU``), which other processes on a busy machine do not eat into; the zygote
also kills the child (its process group) when ``wall_guard`` seconds pass, to catch a case
that hangs without using the CPU. The child's peak resident memory
comes from ``wait4``. A fork of the warm zygote costs a few milliseconds.

The zygote reads requests from its stdin and exits at end of file, so it ends with the
test process that started it (and the kernel kills it, and any child, if its parent
dies: ``PR_SET_PDEATHSIG``). It runs single-threaded (BLAS threads off), so forking it is
safe.

A case can also be a command line (``flatland_ma.cli.main(argv)``, its output captured) or
a Python snippet (API misuse), run in the case's own folder (``tests/isolated_calls.py``);
the zygote imports what a request names in ``warm`` (torch, for checkpoints) once, before
forking. What a child does for a scenario is in ``tests/isolated_scenario.py``, the
``Outcome`` it reports in ``tests/isolated_outcome.py``.

Run this module from the project's root to try a case by hand::

    python -m tests.isolated SCENARIO [OVERRIDES_AS_JSON]
"""

from __future__ import annotations

import atexit
import ctypes
import gc
import importlib
import json
import math
import os
import resource
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

from tests.isolated_outcome import KINDS, MEMORY_BUDGET_MB, OVERRIDES, TIME_LIMIT, Outcome
from tests.isolated_scenario import exception_report, run_case

__all__ = ["KINDS", "OVERRIDES", "Outcome", "Runner", "ZygoteError", "runner"]

ROOT = Path(__file__).resolve().parent.parent
"""The project's root: the zygote imports ``flatland_ma`` from here."""

STEPS = 10
"""Random steps after each of the two resets."""
WARM_UP = ("fruits_poisons", "textured_fruits", "push_box", "maze_goal", "hinged_doors")
"""Shipped scenarios the zygote builds and steps once, so that their kernels (ray
casting, textures, reachability) are loaded before any fork."""
SINGLE_THREADED = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "NUMBA_NUM_THREADS": "1",
}
# -- the client, in the test process -------------------------------------------------------


class ZygoteError(RuntimeError):
    """The zygote itself failed (not a case): it could not start or stopped answering."""


class Runner:
    """A warm zygote serving cases; ``run`` sends one case and returns its ``Outcome``."""

    def __init__(self):
        self._process: subprocess.Popen | None = None

    def run(
        self,
        scenario: str | Path,
        overrides: dict | None = None,
        time_limit: float = TIME_LIMIT,
        memory_budget_mb: float = MEMORY_BUDGET_MB,
        steps: int = STEPS,
        prelude: str = "",
        hang_after: float | None = None,
    ) -> Outcome:
        """Run a case: ``parallel_env(scenario, **overrides)``, then two resets and
        ``steps`` random steps after each. ``prelude`` is Python the child runs first,
        under its limits (to test this runner with cases that hang, abort or allocate).
        ``time_limit`` is CPU seconds; ``hang_after`` the wall-clock seconds after which a
        case is killed as hanging (default ``wall_guard(time_limit)``)."""
        request = {
            "hang_after": hang_after,
            "scenario": str(scenario),
            "overrides": overrides or {},
            "time_limit": time_limit,
            "memory_budget_mb": memory_budget_mb,
            "steps": steps,
            "prelude": prelude,
        }
        return self._ask(request)

    def command(self, argv: list[str], folder: str | Path, prelude: str = "", **limits) -> Outcome:
        """Run ``flatland-ma ARGV`` (``flatland_ma.cli.main``) in ``folder``, after the
        Python ``prelude`` (to test this runner); the outcome is ``exited`` with its status
        and output, unless the case hangs, dies or runs out of memory. ``limits``: see
        ``call``."""
        request = {"call": "command", "argv": [str(a) for a in argv], "prelude": prelude}
        return self.call(request, folder, **limits)

    def snippet(self, code: str, folder: str | Path, **limits) -> Outcome:
        """Run Python ``code`` in ``folder`` (its globals: ``folder``, a ``Path``); the
        outcome is ``returned`` or ``raised`` (with the exception's types and message)."""
        return self.call({"call": "snippet", "code": code}, folder, **limits)

    def call(
        self,
        request: dict,
        folder: str | Path,
        env: dict[str, str] | None = None,
        warm: tuple[str, ...] = (),
        time_limit: float = TIME_LIMIT,
        memory_budget_mb: float = MEMORY_BUDGET_MB,
    ) -> Outcome:
        """Run a command or a snippet with ``folder`` as its working (and temporary)
        folder and ``env`` added to its environment; ``warm``: modules the zygote imports
        once, before this and every later fork (``torch``)."""
        request = {**request, "cwd": str(folder), "env": env or {}, "warm": list(warm)}
        request.update(time_limit=time_limit, memory_budget_mb=memory_budget_mb)
        return self._ask(request)

    def _ask(self, request: dict) -> Outcome:
        # The zygote may first import what the case needs warm (torch: seconds, or more on a
        # busy machine), then the case has its time limit.
        wait = _hang_after(request) + 30.0
        wait += 300.0 if request.get("warm") else 0.0
        line = json.dumps(request, allow_nan=True) + "\n"
        process = self._started()
        try:
            assert process.stdin is not None
            process.stdin.write(line.encode())
            process.stdin.flush()
            answer = self._read_line(process, wait)
        except (OSError, ZygoteError):
            self.close()
            raise
        return Outcome(**json.loads(answer))

    def close(self) -> None:
        process, self._process = self._process, None
        if process is None:
            return
        if process.stdin is not None:
            process.stdin.close()  # end of file: the zygote exits
        try:
            process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()

    def _started(self) -> subprocess.Popen:
        if self._process is not None and self._process.poll() is None:
            return self._process
        env = dict(os.environ, **SINGLE_THREADED)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
        self._process = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--serve"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            env=env,
            cwd=str(ROOT),
        )
        ready = json.loads(self._read_line(self._process, 300.0))
        if not ready.get("ready"):
            raise ZygoteError(f"the zygote did not start: {ready}")
        return self._process

    @staticmethod
    def _read_line(process: subprocess.Popen, timeout: float) -> str:
        """One line from the zygote, or ``ZygoteError`` if none comes within ``timeout``."""
        assert process.stdout is not None
        ready, _, _ = select.select([process.stdout], [], [], timeout)
        if not ready:
            process.kill()
            raise ZygoteError(f"the zygote did not answer within {timeout:g} s")
        line = process.stdout.readline()
        if not line:
            raise ZygoteError(f"the zygote exited (code {process.wait()})")
        return line.decode()


_shared: Runner | None = None


def runner() -> Runner:
    """The test process's one runner (its zygote is started on first use, closed at exit),
    shared by every test module that runs isolated cases."""
    global _shared
    if _shared is None:
        _shared = Runner()
        atexit.register(_shared.close)
    return _shared


# -- the zygote ----------------------------------------------------------------------------


def serve() -> None:
    """The zygote's loop: warm up, say so, then one outcome line per request line."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the test process decides when to stop
    _die_with_parent()
    answers = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)  # anything printed by the package goes to stderr, not into the answers
    _warm_up()
    gc.collect()
    gc.freeze()  # children then do not touch (and copy) the warm objects when collecting
    answers.write(json.dumps({"ready": True}) + "\n")
    answers.flush()
    warmed: set[str] = set()
    for line in sys.stdin:
        request = json.loads(line)
        _warm_modules(request.get("warm", ()), warmed)
        outcome = run_forked(request)
        answers.write(json.dumps(outcome.__dict__, allow_nan=True) + "\n")
        answers.flush()


def _warm_up() -> None:
    import flatland_ma

    for name in WARM_UP:
        env = flatland_ma.parallel_env(name)
        env.reset(seed=0)
        for _ in range(3):
            env.step({a: env.action_space(a).sample() for a in env.agents})


def _warm_modules(names, warmed: set[str]) -> None:
    """Import the modules a request needs that this zygote has not imported yet, once, so
    that its children start warm (a module that fails to import is left to the case)."""
    todo = [name for name in names if name not in warmed]
    for name in todo:
        warmed.add(name)
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - the case will meet it again and report it
            continue
    if todo:
        gc.collect()
        gc.freeze()


def run_forked(request: dict) -> Outcome:
    """Run one case in a forked child; kill it after the time limit."""
    time_limit = float(request["time_limit"])
    read_end, write_end = os.pipe()
    start = time.monotonic()
    pid = os.fork()
    if pid == 0:  # the child: never returns
        os.close(read_end)
        _child(request, write_end)
    os.close(write_end)
    try:
        os.setpgid(pid, pid)  # also done by the child: whichever runs first
    except OSError:
        pass
    data, waited = _collect(read_end, pid, start + _hang_after(request))
    os.close(read_end)
    timed_out = waited is None
    if timed_out:
        _kill(pid)
        waited = os.wait4(pid, 0)
    _, status, usage = waited
    wall = time.monotonic() - start
    try:  # processes the case started and left behind (its group outlives it)
        os.killpg(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    start_line, _, report = data.partition(b"\n")
    cpu_s = usage.ru_utime + usage.ru_stime
    outcome = _judge(report, status, timed_out, time_limit, cpu_s, _hang_after(request))
    outcome.wall_s = wall
    outcome.peak_rss_mb = usage.ru_maxrss / 1024
    try:
        outcome.start_rss_mb = float(start_line)
    except ValueError:  # it died before saying
        pass
    outcome.time_limit = time_limit
    outcome.memory_limit_mb = float(request["memory_budget_mb"])
    return outcome


def _collect(read_end: int, pid: int, deadline: float) -> tuple[bytes, tuple | None]:
    """The child's report, read as it comes (so that a long one cannot fill the pipe and
    block the child), and its ``wait4`` result once it exits; None if the deadline
    passes first."""
    chunks = []
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            return b"".join(chunks), None
        ready, _, _ = select.select([read_end], [], [], left)
        if not ready:
            continue
        chunk = os.read(read_end, 1 << 16)
        if not chunk:
            break
        chunks.append(chunk)
    while time.monotonic() < deadline:  # it exits right after closing the pipe
        waited = os.wait4(pid, os.WNOHANG)
        if waited[0]:
            return b"".join(chunks), waited
        time.sleep(0.002)
    return b"".join(chunks), None


def _kill(pid: int) -> None:
    for kill in (os.killpg, os.kill):
        try:
            kill(pid, signal.SIGKILL)
            return
        except ProcessLookupError:
            continue


def wall_guard(time_limit: float) -> float:
    """Wall-clock seconds after which a case that has not used up its CPU time is taken to
    hang: a loaded machine may give a case a small share of a core."""
    return max(6.0 * time_limit, 120.0)


def _hang_after(request: dict) -> float:
    given = request.get("hang_after")
    return float(given) if given else wall_guard(float(request["time_limit"]))


def _judge(
    data: bytes, status: int, timed_out: bool, time_limit: float, cpu_s: float, hang: float
) -> Outcome:
    if timed_out:
        return Outcome("timeout", detail=f"still running after {hang:g} s (hangs); killed")
    if os.WIFSIGNALED(status) and (
        os.WTERMSIG(status) == signal.SIGXCPU
        or (os.WTERMSIG(status) == signal.SIGKILL and cpu_s >= time_limit)
    ):
        return Outcome("timeout", detail=f"used its {time_limit:g} s of CPU time; killed")
    if os.WIFSIGNALED(status):
        name = signal.Signals(os.WTERMSIG(status)).name
        return Outcome("crashed", detail=f"killed by {name}")
    code = os.WEXITSTATUS(status)
    try:
        report = json.loads(data)
    except ValueError:
        return Outcome("crashed", detail=f"exited with code {code} without a report")
    return Outcome(**report)


# -- the child -----------------------------------------------------------------------------


def _child(request: dict, write_end: int) -> None:
    """Limit this process, run the case, write the report, exit. Never returns."""
    code = 0
    try:
        _write(write_end, b"%f\n" % (_status_kib("VmRSS") / 1024))
        os.setpgid(0, 0)
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        _die_with_parent()
        _quiet()
        _limit(request)
        if "call" in request:
            from tests.isolated_calls import run_call

            report = run_call(request)
        else:
            exec(request["prelude"], {})
            report = run_case(request)
    except BaseException as err:  # noqa: BLE001 - anything at all is reported
        report = exception_report("memory" if isinstance(err, MemoryError) else "crashed", err)
        code = 1
    try:
        data = json.dumps(report, allow_nan=True).encode()
    except BaseException:  # noqa: BLE001
        data = json.dumps({"kind": "crashed", "detail": "the report could not be written"})
        data = data.encode()
    try:
        _write(write_end, data)
        os.close(write_end)
    finally:
        os._exit(code)


def _write(fd: int, data: bytes) -> None:
    while data:
        data = data[os.write(fd, data) :]


def _quiet() -> None:
    """Send the child's output nowhere (warnings are reported with the outcome)."""
    null = os.open(os.devnull, os.O_RDWR)
    for fd in (0, 1, 2):
        os.dup2(null, fd)
    os.close(null)


def _limit(request: dict) -> None:
    """Cap the address space at the current size plus the budget, and the CPU time at the
    case's time limit (SIGXCPU, then SIGKILL a second later); no core files."""
    vm = _status_kib("VmSize") * 1024
    budget = int(float(request["memory_budget_mb"]) * 1024 * 1024)
    resource.setrlimit(resource.RLIMIT_AS, (vm + budget, vm + budget))
    cpu = math.ceil(float(request["time_limit"]))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


# -- processes -----------------------------------------------------------------------------


def _status_kib(field_name: str) -> int:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(field_name + ":"):
                return int(line.split()[1])
    raise LookupError(field_name)


def _die_with_parent() -> None:
    """Ask the kernel to kill this process when its parent dies (Linux only)."""
    pr_set_pdeathsig = 1
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):
        return
    if os.getppid() == 1:  # the parent died before the request was made
        os._exit(1)


def _main(argv: list[str]) -> None:
    if argv[:1] == ["--serve"]:
        serve()
        return
    if not argv:
        print(__doc__)
        return
    overrides = json.loads(argv[1]) if len(argv) > 1 else {}
    outcome = runner().run(argv[0], overrides)
    print(outcome.summary())
    for problem in outcome.problems:
        print(f"  {problem['source']}:{problem['line']}: {problem['key']}: {problem['message']}")


if __name__ == "__main__":
    _main(sys.argv[1:])
