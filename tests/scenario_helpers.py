"""Writing scenario files in tests and collecting the problems their loading reports."""

import textwrap

import pytest

from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import load_scenario


def write(tmp_path, text, name="s.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def problems(path, **overrides):
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, **overrides)
    return info.value.problems
