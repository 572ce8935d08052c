"""Malformed stream files, fuzzed as scenario files are (tests/scenario/test_scenario_fuzz.py):
whatever a file says, loading it either works or raises ``ScenarioError`` naming the file
and, for a fault at a key, the line and the key path. No other exception."""

from __future__ import annotations

import copy
import tempfile
from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flatland_ma.lifelong import list_streams, load_stream
from flatland_ma.lifelong.streams import stream_dir
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import scenario_dir
from tests.scenario.test_scenario_fuzz import mangle, mutate

NAMES = list_streams()
FILES = {name: stream_dir() / f"{name}.yaml" for name in NAMES}
TEXTS = {name: path.read_bytes() for name, path in FILES.items()}
DATA = {name: yaml.safe_load(text) for name, text in TEXTS.items()}
FUZZ = settings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


def load(path: Path) -> None:
    """Load ``path``: it must work, or fail with a located ScenarioError."""
    try:
        load_stream(path)
    except ScenarioError as err:
        assert err.problems
        scenarios = {str(p) for p in scenario_dir().glob("*.yaml")}
        for problem in err.problems:
            assert problem.source in {str(path), *scenarios}, str(problem)
            assert problem.message and "internal error" not in problem.message, str(problem)
            if problem.path and problem.source == str(path):
                assert problem.line is not None, str(problem)


@FUZZ
@given(data=st.data())
def test_mutated_stream_data_fails_only_with_located_errors(data):
    name = data.draw(st.sampled_from(NAMES))
    doc = copy.deepcopy(DATA[name])
    for _ in range(data.draw(st.integers(1, 3))):
        mutate(data, doc)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{name}.yaml"
        path.write_text(yaml.safe_dump(doc, sort_keys=False))
        load(path)


@FUZZ
@given(data=st.data())
def test_mangled_stream_text_fails_only_with_located_errors(data):
    name = data.draw(st.sampled_from(NAMES))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{name}.yaml"
        path.write_bytes(mangle(data, TEXTS[name]))
        load(path)
