"""The shipped scenario files: where they are, their names, and their index.

The index (``scenarios/index.json``) holds what registering Gymnasium ids needs from each
shipped scenario (its version, number of agents and episode length) and a hash of every
shipped scenario file, so that ``import flatland_ma`` registers the ids without parsing
and validating the files: ``read_index`` gives the entries only while the hash still
matches the files (else None, and the files are parsed). ``make reference`` writes it
from the files (``flatland_ma.scenario.index``); a test holds the shipped one to them.

This module imports no models (pydantic's models take longer to build than the files
take to read): the loader re-exports its names.
"""

from __future__ import annotations

import hashlib
import json
from importlib import resources
from pathlib import Path

SCENARIO_PACKAGE = "flatland_ma.scenarios"
"""The package the shipped scenario files install as: ``pyproject.toml`` maps the
top-level ``scenarios/`` folder onto it."""
SCENARIO_SUFFIXES = (".yaml", ".yml")
INDEX_FILE = "index.json"
"""The index of the shipped scenarios, beside them."""


def scenario_dir() -> Path:
    """The folder of scenario files shipped with the package, wherever it is installed
    (pip unpacks wheels, so it is a folder on disk in editable and wheel installs alike)."""
    return Path(str(resources.files(SCENARIO_PACKAGE)))


def scenario_files(folder: Path | None = None) -> list[Path]:
    """The scenario files in ``folder`` (by default the shipped ones), sorted by name."""
    folder = folder or scenario_dir()
    found = [p for p in folder.iterdir() if p.suffix in SCENARIO_SUFFIXES]
    return sorted(found, key=lambda p: (p.stem, p.suffix))


def list_scenarios() -> list[str]:
    """Names of the scenarios shipped with the package, sorted."""
    return [p.stem for p in scenario_files()]


def stream_dir() -> Path:
    """The folder of the shipped task streams (``flatland_ma.lifelong`` reads them)."""
    return scenario_dir() / "streams"


def list_streams() -> list[str]:
    """Names of the shipped streams, sorted."""
    return sorted(p.stem for p in stream_dir().glob("*.yaml"))


def files_hash(folder: Path | None = None) -> str:
    """A hash of every scenario file's name and bytes (in ``folder``; by default the
    shipped ones)."""
    digest = hashlib.sha256()
    for path in scenario_files(folder):
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def read_index() -> dict[str, dict[str, int]] | None:
    """``{name: {"version", "n_agents", "max_steps"}}`` of every shipped scenario, from
    the index, or None if there is none or the files changed since it was written."""
    try:
        index = json.loads((scenario_dir() / INDEX_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(index, dict) or index.get("files_sha256") != files_hash():
        return None
    return index.get("scenarios")
