"""A spec read from a file says which (``source``) and where each key path was written
(``marks``), for the faults found after validation; neither is part of what the spec
validates, serialises or compares."""

from __future__ import annotations

import json
import pickle

from flatland_ma.scenario.errors import SpecError
from flatland_ma.scenario.loader import load_scenario
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.studio.scenarios import spec_from_text

TEXT = """\
extends: fruits_poisons
n_agents: 2
"""


def test_a_scenario_file_is_named_and_its_keys_lines_are_kept(tmp_path):
    path = tmp_path / "two.yaml"
    path.write_text(TEXT)
    spec = load_scenario(path)
    assert spec.source == str(path)
    assert spec.marks[("n_agents",)] == (str(path), 2)
    problem = spec.locate(SpecError(("n_agents",), "too many")).problems[0]
    assert (problem.source, problem.line, problem.message) == (str(path), 2, "too many")


def test_where_a_spec_came_from_is_not_part_of_it(tmp_path):
    path = tmp_path / "two.yaml"
    path.write_text(TEXT)
    spec = load_scenario(path)
    again = ScenarioSpec.model_validate(spec.model_dump())
    assert again.source == "<spec>" and again.marks == {}
    assert again == spec
    assert again.model_dump_json() == spec.model_dump_json()
    schema = json.dumps(ScenarioSpec.model_json_schema())
    assert '"source"' not in schema and '"marks"' not in schema and "_origin" not in schema
    copied = pickle.loads(pickle.dumps(spec))
    assert copied.source == str(path) and copied.marks == spec.marks
    assert spec.model_copy().source == str(path)


def test_the_studios_text_is_named_as_the_editor_names_it():
    spec = spec_from_text(TEXT, source="editor:two.yaml")
    assert spec.source == "editor:two.yaml"
    assert spec.marks[("n_agents",)] == ("editor:two.yaml", 2)
