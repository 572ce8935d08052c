"""Reading a file from outside: the one door every file of this package's formats goes
through (scenarios, streams, suites, a lifelong run's summaries and evaluation tables).

Only a regular file is read: a directory, a FIFO, a socket, a device (``/dev/zero``) or a
symlink loop where a file belongs is refused before a byte is read, and the file is opened
without blocking, so nothing can hang the reader. A file may hold at most ``limit`` bytes
(``MAX_FILE_BYTES`` unless the caller says less or more); a file that grows while it is
read is cut at the limit and refused. Text must be UTF-8: an error names the file and the
line of the first byte that is not. Every fault is a ``ScenarioError`` naming the file.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from flatland_ma.scenario.errors import Problem, ScenarioError

MAX_FILE_BYTES = 16 * 2**20
"""The largest file read by default: 16 MiB (the largest shipped scenario is a few KiB)."""
_CHUNK = 2**20
_OPEN_FLAGS = (
    os.O_RDONLY
    | getattr(os, "O_NONBLOCK", 0)  # a FIFO opens at once instead of waiting for a writer
    | getattr(os, "O_NOCTTY", 0)
    | getattr(os, "O_CLOEXEC", 0)
    | getattr(os, "O_BINARY", 0)
)


def _fault(source: str, message: str, line: int | None = None) -> ScenarioError:
    return ScenarioError([Problem(source, line, (), message)])


def _kind(mode: int) -> str:
    """What a file that is not a regular file is, in words."""
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _open_error(source: str, err: OSError) -> ScenarioError:
    if err.errno == errno.ELOOP:
        return _fault(source, "a loop of symbolic links, not a file")
    if err.errno == errno.ENOENT:
        return _fault(source, "no such file")
    if err.errno == errno.EISDIR:
        return _fault(source, "a directory, not a file")
    return _fault(source, f"cannot read the file: {err.strerror or err}")


def check_regular_file(path: str | Path) -> Path:
    """``path`` if it names a regular file (following symbolic links); ``ScenarioError``
    saying what it is instead. Nothing is opened."""
    source = str(path)
    try:
        mode = os.stat(path).st_mode
    except OSError as err:
        raise _open_error(source, err) from None
    except ValueError as err:  # e.g. a NUL character in the name
        raise _fault(source, f"not a file name: {err}") from None
    if not stat.S_ISREG(mode):
        raise _fault(source, f"{_kind(mode)}, not a regular file")
    return Path(path)


def read_bytes(path: str | Path, limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them; ``ScenarioError``
    naming the file for anything else (see the module's docstring)."""
    source = str(path)
    try:
        fd = os.open(path, _OPEN_FLAGS)
    except OSError as err:
        raise _open_error(source, err) from None
    except ValueError as err:
        raise _fault(source, f"not a file name: {err}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise _fault(source, f"{_kind(info.st_mode)}, not a regular file")
        if info.st_size > limit:
            raise _fault(source, f"{info.st_size:,} bytes: larger than the {limit:,} allowed")
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, min(_CHUNK, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > limit:
            raise _fault(source, f"grew past the {limit:,} bytes allowed while it was read")
        return b"".join(chunks)
    except OSError as err:
        raise _fault(source, f"cannot read the file: {err.strerror or err}") from None
    finally:
        os.close(fd)


def read_text(path: str | Path, limit: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text of the regular file ``path`` (``read_bytes``); ``ScenarioError``
    naming the file, and the line of a byte that is not UTF-8."""
    data = read_bytes(path, limit)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        message = f"not UTF-8 text: {err.reason} (byte {data[err.start]:#04x})"
        raise _fault(str(path), message, line) from None
