"""The child's side of a command-line or snippet case (``tests/isolated.py`` forks it).

A *command* runs ``flatland_ma.cli.main(argv)`` as the ``flatland-ma`` script would: its
exit status (``SystemExit``'s code, the value ``main`` returns, or 1 with a traceback
printed when an exception escapes), what it wrote to stdout and stderr, whether that holds
a Python traceback or "internal error". A *snippet* is Python exec'd with ``folder`` (a
``Path``) in its globals: it returns, or raises an exception whose types, message and (for
a ``ScenarioError``) located problems are reported.

Either runs with the case's folder as its working folder and ``TMPDIR``, so that whatever
it writes by default lands there; ``env`` is added to its environment.
"""

from __future__ import annotations

import io
import os
import sys
import traceback
import warnings
from pathlib import Path

KEPT = 4000
"""Characters of each output kept at its head, and as many at its tail."""
CAPTURED = 1 << 20
"""Characters of each output held at all (the rest is counted, not kept)."""
TRACEBACK = "Traceback (most recent call last)"
INTERNAL = "internal error"


class Captured(io.StringIO):
    """An output that holds its first ``CAPTURED`` characters and counts the rest."""

    def __init__(self):
        super().__init__()
        self.dropped = 0

    def write(self, text: str) -> int:
        room = CAPTURED - self.tell()
        if len(text) > room:
            self.dropped += len(text) - max(room, 0)
            text = text[: max(room, 0)]
        super().write(text)
        return len(text)

    def isatty(self) -> bool:
        return False


def run_call(request: dict) -> dict:
    """Run the request's command or snippet where it says; the report's fields are
    ``Outcome``'s."""
    os.environ.update(request.get("env") or {})
    os.environ["TMPDIR"] = request["cwd"]
    os.chdir(request["cwd"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if request["call"] == "command":
            report = _command(request["argv"], request.get("prelude", ""))
        else:
            report = _snippet(request["code"], Path(request["cwd"]))
    report["warnings"] = sorted({f"{w.category.__name__}: {w.message}" for w in caught or []})[:20]
    return report


def _command(argv: list[str], prelude: str) -> dict:
    out, err = Captured(), Captured()
    sys.stdout, sys.stderr = out, err
    kind = "exited"
    try:
        exec(prelude, {})
        from flatland_ma.cli import main

        code = _status(main(argv))
    except SystemExit as exit:
        if exit.code is not None and not isinstance(exit.code, int):
            print(exit.code, file=err)
        code = _status(exit.code)
    except BaseException as error:  # noqa: BLE001 - what Python prints, then status 1
        traceback.print_exception(type(error), error, error.__traceback__, file=err)
        kind = "memory" if isinstance(error, MemoryError) else kind
        code = 1
    finally:
        sys.stdout, sys.stderr = sys.__stdout__, sys.__stderr__
    stdout, stderr = out.getvalue(), err.getvalue()
    return {
        "kind": kind,
        "exit_code": code,
        "stdout": _kept(stdout, out.dropped),
        "stderr": _kept(stderr, err.dropped),
        "printed_traceback": TRACEBACK in stderr or TRACEBACK in stdout,
        "internal_error": INTERNAL in stderr or INTERNAL in stdout,
        "detail": stderr.strip().splitlines()[-1][:KEPT] if stderr.strip() else "",
    }


def _status(code) -> int:
    if code is None:
        return 0
    return code if isinstance(code, int) else 1


def _snippet(code: str, folder: Path) -> dict:
    try:
        exec(compile(code, "<snippet>", "exec"), {"folder": folder, "__name__": "__snippet__"})
    except BaseException as error:  # noqa: BLE001 - the outcome of the case
        message = f"{type(error).__name__}: {error}"
        report = {
            "kind": "memory" if isinstance(error, MemoryError) else "raised",
            "raised_types": [cls.__name__ for cls in type(error).__mro__],
            "detail": message[: 2 * KEPT],
            "internal_error": INTERNAL in message,
            "traceback": "".join(traceback.format_exception(error))[-KEPT:],
            "problems": _problems(error),
        }
        return report
    return {"kind": "returned"}


def _problems(error: BaseException) -> list[dict]:
    """A ``ScenarioError``'s problems, as the scenario cases report them."""
    problems = getattr(error, "problems", None)
    if not isinstance(problems, list):
        return []
    from flatland_ma.scenario.errors import format_path

    return [
        {
            "source": p.source,
            "line": p.line,
            "key": format_path(p.path),
            "message": p.message[:KEPT],
        }
        for p in problems[:50]
    ]


def _kept(text: str, dropped: int) -> str:
    if len(text) <= 2 * KEPT and not dropped:
        return text
    cut = len(text) - 2 * KEPT + dropped
    return f"{text[:KEPT]}\n[... {cut} characters ...]\n{text[-KEPT:]}"
