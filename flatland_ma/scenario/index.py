"""The shipped scenarios' index (``flatland_ma.scenario.shipped``), written from the files
themselves: each parsed and validated for its version, number of agents and episode
length. ``make reference`` writes it beside the scenarios (``flatland_ma.scenario.reference``)."""

from __future__ import annotations

import json
from pathlib import Path

from flatland_ma.scenario.loader import load_scenario
from flatland_ma.scenario.shipped import files_hash, scenario_files


def index_of_files(folder: Path | None = None) -> dict:
    """The index of the scenario files in ``folder`` (by default the shipped ones)."""
    entries = {}
    for path in scenario_files(folder):
        spec = load_scenario(path)
        entries[path.stem] = {
            "version": spec.version,
            "n_agents": spec.n_agents,
            "max_steps": spec.episode.max_steps,
        }
    return {"files_sha256": files_hash(folder), "scenarios": entries}


def index_text(folder: Path | None = None) -> str:
    """The index as the file holds it."""
    return json.dumps(index_of_files(folder), indent=1, sort_keys=True) + "\n"
