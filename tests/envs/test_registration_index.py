"""``import flatland_ma`` registers the Gymnasium ids from the shipped scenarios' index,
without parsing a scenario file or building a model; the index is the files', and when
the files change without it, they are parsed instead."""

import json
import shutil
import subprocess
import sys

import flatland_ma
from flatland_ma.envs import registration
from flatland_ma.scenario import shipped
from flatland_ma.scenario.index import index_of_files, index_text
from flatland_ma.scenario.shipped import INDEX_FILE, read_index


def test_the_shipped_index_is_the_files():
    written = (shipped.scenario_dir() / INDEX_FILE).read_text(encoding="utf-8")
    assert written == index_text(), "scenarios/index.json is out of date: run `make reference`"
    assert read_index() == index_of_files()["scenarios"]


def test_importing_the_package_parses_no_scenario_and_registers_every_id():
    code = (
        "import json, sys, flatland_ma; "
        "print(json.dumps([flatland_ma.GYM_IDS, sorted(m for m in sys.modules "
        "if m.startswith(('pydantic', 'flatland_ma.scenario.')))]))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    ids, modules = json.loads(out.stdout)
    assert ids == flatland_ma.GYM_IDS
    assert modules == ["flatland_ma.scenario.shipped"]  # no loader, no models, no pydantic
    singles = {n for n, e in index_of_files()["scenarios"].items() if e["n_agents"] == 1}
    assert ids == [registration.gym_id(n) for n in sorted(singles)]


def test_files_changed_without_their_index_are_parsed_instead(tmp_path, monkeypatch):
    for path in shipped.scenario_dir().glob("*.yaml"):
        shutil.copy(path, tmp_path)
    (tmp_path / INDEX_FILE).write_text(index_text(tmp_path), encoding="utf-8")
    monkeypatch.setattr(shipped, "scenario_dir", lambda: tmp_path)
    assert read_index() is not None
    push = tmp_path / "push_box.yaml"
    push.write_text(push.read_text() + "version: 3\n")
    assert read_index() is None
    assert registration.single_agent_scenarios()["push_box"][0] == 3
    assert registration.gym_id("push_box") == "flatland_ma/PushBox-v3"
