"""The format's reference (``docs/scenarios.md``) and JSON schema (``scenario.schema.json``)
are written from the models by ``make reference``; they match the code, every model has its
section, and the JSON schema takes every shipped file and rejects what the loader rejects."""

import json
from pathlib import Path

import pytest
import yaml
from jsonschema import Draft202012Validator

import flatland_ma
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.json_schema import file_schema, schema_text
from flatland_ma.scenario.loader import read_raw, scenario_path, schema_path, validate
from flatland_ma.scenario.reference import render, sections

ROOT = Path(__file__).resolve().parents[2]


def test_the_format_reference_matches_the_schema():
    """docs/scenarios.md is written from the schema: regenerate it with ``make reference``."""
    written = (ROOT / "docs" / "scenarios.md").read_text(encoding="utf-8")
    assert written == render(), "docs/scenarios.md is out of date: run `make reference`"


def test_the_shipped_json_schema_matches_the_models():
    """scenarios/scenario.schema.json too: regenerate it with ``make reference``."""
    assert schema_path() == ROOT / "scenarios" / "scenario.schema.json"
    written = schema_path().read_text(encoding="utf-8")
    assert written == schema_text(), "scenario.schema.json is out of date: run `make reference`"


def test_every_model_has_its_section_and_every_section_its_keys():
    schema = file_schema()
    models = {name for name, d in schema["$defs"].items() if d.get("type") == "object"}
    found = sections(schema)
    assert models <= {name for s in found for name in s.key.split("|")}
    text = render()
    for section in found:
        for key in section.schema["properties"]:
            assert f"| `{key}` |" in text
    assert "## `obstacles[]` with `shape: circle`" in text
    assert "## `layout.generators[]` with `generator: maze`" in text
    assert "## `doors[]` and `rooms[].openings[].door`" in text
    assert "| `floor_color` | colour | `beige` |" in text


@pytest.fixture(scope="module")
def validator() -> Draft202012Validator:
    schema = json.loads(schema_path().read_text(encoding="utf-8"))
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema)


def schema_errors(validator, data) -> list[str]:
    return [
        f"{'.'.join(map(str, e.absolute_path))}: {e.message}" for e in validator.iter_errors(data)
    ]


@pytest.mark.parametrize("name", flatland_ma.list_scenarios())
def test_every_shipped_scenario_is_valid_under_the_json_schema(validator, name):
    data = yaml.safe_load(scenario_path(name).read_text(encoding="utf-8"))
    assert schema_errors(validator, data) == []


@pytest.mark.parametrize("name", flatland_ma.list_scenarios())
def test_a_spec_written_back_is_a_valid_file_that_reads_the_same(validator, name):
    """Colours are written back as names or "#rrggbb", so a dump is a scenario file."""
    spec = validate(read_raw(name)[0], {}, name)
    written = json.loads(spec.model_dump_json())
    assert schema_errors(validator, written) == []
    assert validate(written, {}, name) == spec == validate(spec.model_dump(), {}, name)


GOOD = {
    "extends": "fruits_poisons",
    "arena": {"size": [300, 200], "floor_color": "#A0b0C0", "wall": {"color": [10, 20, 30]}},
    "zones": [{"rect": [0, 0, 50, 50], "reward": 1, "color": "navy"}],
    "layout": {"generators": [{"generator": "maze", "cell": 40, "color": None}]},
    "obstacles": [{"shape": "circle", "position": [100, 100], "radius": 8}],
    "agent": {"colors": ["red", "#00ff00"], "spawn": {"area": [1, 1, 40, 40]}},
    "reference": {"solver": "planner", "min_score": 5},
}
BAD = [
    {"arena": {"floor_colour": "beige"}},
    {"arena": {"floor_color": "chartreuse"}},
    {"arena": {"floor_color": "#abc"}},
    {"arena": {"floor_color": [0.5, 0.5, 0.5]}},
    {"arena": {"floor_color": [1, 2, 300]}},
    {"zones": [{"rect": [0, 0, 50], "reward": 1}]},
    {"obstacles": [{"shape": "star", "position": [1, 1]}]},
    {"obstacles": [{"shape": "circle", "position": [1, 1]}]},
    {"n_agents": 0},
    {"episode": {"max_steps": "10"}},
    {"reference": {"solver": "oracle", "min_score": 5}},
    {"reference": {"solver": "planner"}},
]


def test_the_json_schema_takes_what_files_write(validator):
    assert schema_errors(validator, GOOD) == []
    without_extends = {k: v for k, v in GOOD.items() if k != "extends"}
    assert validate(without_extends, {}, "<test>").reference.min_score == 5


@pytest.mark.parametrize("data", BAD, ids=lambda d: json.dumps(d)[:40])
def test_the_json_schema_rejects_what_the_loader_rejects(validator, data):
    assert schema_errors(validator, data)
    with pytest.raises(ScenarioError):
        validate(data, {}, "<test>")
