"""Files inside the folders a studio was given, and nowhere else.

A client names a file by a plain name (``my_world.yaml``, or ``runs/ppo/seed_0.safetensors``
for a checkpoint under its folder): no absolute path, no ``..``, no hidden parts, no
backslash or control character. The path it makes is resolved, symbolic links followed,
and must still lie inside the folder: a link that points out is refused, and a file is
written only where no link stands. Reads go through the scenario format's one door
(``scenario.files``): a regular file, within a size limit. Each refusal is a
``FolderError`` saying why.
"""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.files import read_bytes

SCENARIO_SUFFIXES = (".yaml", ".yml")
CHECKPOINT_SUFFIXES = (".safetensors",)
MAX_NAME = 200
"""Characters in a name a client gives."""
MAX_LISTED = 500
"""Files listed per folder (the rest are left out of the gallery)."""
MAX_DEPTH = 4
"""Folders below a checkpoint folder that are searched for checkpoints."""
_PART = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]*")


class FolderError(ValueError):
    """A name or a file a client may not use; the message says why."""


def check_name(name: object, suffixes: tuple[str, ...], nested: bool = False) -> str:
    """``name`` if it is a plain relative file name with one of ``suffixes`` (with folders
    between slashes if ``nested``), else ``FolderError``."""
    if not isinstance(name, str) or not 0 < len(name) <= MAX_NAME:
        raise FolderError(f"a file name is text of 1 to {MAX_NAME} characters")
    parts = name.split("/")
    if not nested and len(parts) > 1:
        raise FolderError(f"{name!r}: a plain file name is wanted, without folders")
    for part in parts:
        if part in ("", ".", "..") or not _PART.fullmatch(part):
            raise FolderError(
                f"{name!r}: each part of a name is letters, digits, _ . - (not starting "
                "with . or -); no '..', absolute path or backslash"
            )
    if not name.endswith(suffixes):
        raise FolderError(f"{name!r}: the name must end with {' or '.join(suffixes)}")
    return name


def inside(root: Path, name: str) -> Path:
    """The path of ``name`` in ``root``, refused if it resolves outside ``root`` (through
    a symbolic link anywhere on the way)."""
    base = root.resolve()
    path = base / name
    resolved = path.resolve()
    if not resolved.is_relative_to(base):
        raise FolderError(f"{name!r} leads outside its folder (a symbolic link)")
    return path


def read_file(root: Path, name: str, suffixes: tuple[str, ...], limit: int) -> str:
    """The text of the file ``name`` in ``root``: UTF-8, a regular file of at most
    ``limit`` bytes."""
    path = inside(root, check_name(name, suffixes))
    try:
        data = read_bytes(path, limit=limit)
    except ScenarioError as err:
        raise FolderError(f"{name}: {err.problems[0].message}") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise FolderError(f"{name}: not UTF-8 text") from None


def write_file(root: Path, name: str, text: str, limit: int, overwrite: bool) -> Path:
    """Write ``text`` to ``name`` in ``root`` (a new file, or an existing regular file if
    ``overwrite``): to a temporary file first, then moved into place."""
    data = text.encode("utf-8")
    if len(data) > limit:
        raise FolderError(f"{len(data):,} bytes; a scenario file holds at most {limit:,}")
    path = inside(root, check_name(name, SCENARIO_SUFFIXES))
    if os.path.lexists(path):
        if path.is_symlink() or not path.is_file():
            raise FolderError(f"{name!r} is there and is not a regular file")
        if not overwrite:
            raise FolderError(f"{name!r} exists already (save it with overwrite to replace it)")
    handle, temporary = tempfile.mkstemp(dir=root.resolve(), prefix=".studio-", suffix=".tmp")
    try:
        with os.fdopen(handle, "wb") as out:
            out.write(data)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return path


def list_files(root: Path, suffixes: tuple[str, ...], depth: int = 0) -> list[str]:
    """Names of the regular files in ``root`` (and ``depth`` folders below) with one of
    ``suffixes``, sorted; links that lead outside and unusable names are left out."""
    base = root.resolve()
    found: list[str] = []
    folders = [(base, 0)]
    while folders and len(found) < MAX_LISTED:
        folder, level = folders.pop()
        try:
            entries = sorted(os.scandir(folder), key=lambda e: e.name)
        except OSError:
            continue
        for entry in entries:
            relative = Path(entry.path).relative_to(base).as_posix()
            if not _PART.fullmatch(entry.name):
                continue
            if not Path(entry.path).resolve().is_relative_to(base):
                continue
            if entry.is_dir() and level < depth:
                folders.append((Path(entry.path), level + 1))
            elif entry.is_file() and entry.name.endswith(suffixes):
                found.append(relative)
    return sorted(found)[:MAX_LISTED]
