"""Running ``python -m MODULE ARGS`` for the learners' smoke tests, in a fresh process each
time but without paying the imports each time.

A learner's smoke run is a few hundred steps; starting its process costs more: importing
torch, its compiler stack (which the first optimiser pulls in) and this package takes
several seconds of CPU. So the runs are forked from a ``forkserver`` that imported those
once (``multiprocessing``'s own preloading). Each run is still a process of its own: its
module runs as ``__main__`` with its own arguments, environment, threads and seeds, and a
crash ends only it. Nothing has run in the server but imports, so forking it is safe.
"""

from __future__ import annotations

import io
import multiprocessing
import os
import runpy
import subprocess
import sys
import tempfile
import traceback
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

PRELOAD = ["torch", "torch._dynamo", "torch.optim", "tyro", "flatland_ma.envs.vector"]
"""What the server imports before it forks: the slow imports every learner makes."""

# The server inherits this process's environment when it starts: OpenMP's threads must
# sleep when idle there too (tests/conftest.py asks for it before anything imports torch),
# or every run forked from it spins them.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
_context = multiprocessing.get_context("forkserver")
_context.set_forkserver_preload(PRELOAD)


def _main(module: str, args: list[str], env: dict, cwd: str, out: str) -> None:
    os.environ.clear()
    os.environ.update(env)
    os.chdir(cwd)
    sys.argv = [module, *args]
    stdout, stderr, code = io.StringIO(), io.StringIO(), 0
    with redirect_stdout(stdout), redirect_stderr(stderr):
        try:
            runpy.run_module(module, run_name="__main__", alter_sys=True)
        except SystemExit as end:  # as the interpreter ends: a message goes to stderr
            code = end.code if isinstance(end.code, int) else (0 if end.code is None else 1)
            if end.code is not None and not isinstance(end.code, int):
                print(end.code, file=sys.stderr)
        except BaseException:  # the run's failure, reported to the test as its output
            traceback.print_exc()
            code = 1
    Path(out).write_text(f"{code}\n{stdout.getvalue()}\0{stderr.getvalue()}")


def run(module: str, args: list[str], env: dict, cwd: Path, out: Path, timeout: float):
    """``(returncode, stdout, stderr)`` of ``python -m module *args`` run in ``cwd`` with
    ``env``; its output goes through the file ``out``. A run still going after ``timeout``
    seconds is killed (a guard against a hang, not a time to beat)."""
    process = _context.Process(target=_main, args=(module, args, env, str(cwd), str(out)))
    process.start()
    process.join(timeout)
    if process.is_alive():
        process.kill()
        process.join()
        return -9, "", f"killed after {timeout} s"
    if not out.exists():
        return process.exitcode, "", f"the run ended with code {process.exitcode} and no output"
    code, _, rest = out.read_text().partition("\n")
    stdout, _, stderr = rest.partition("\0")
    return int(code), stdout, stderr


def run_module(
    module: str, *args: str, env: dict | None = None, cwd: Path = ROOT, timeout: float = 1200.0
) -> subprocess.CompletedProcess:
    """What ``subprocess.run([python, "-m", module, *args], capture_output=True,
    text=True)`` gives, from a run forked from the warm server."""
    with tempfile.TemporaryDirectory() as folder:
        code, out, err = run(
            module, list(args), dict(os.environ if env is None else env), cwd,
            Path(folder) / "output", timeout,
        )  # fmt: skip
    return subprocess.CompletedProcess([sys.executable, "-m", module, *args], code, out, err)
