"""Writing scenario files in tests and collecting the problems their loading reports."""

import textwrap

import pytest

from flatland_ma.build.feasibility import check_scenario
from flatland_ma.scenario.errors import ScenarioError


def write(tmp_path, text, name="s.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def problems(path, **overrides):
    with pytest.raises(ScenarioError) as info:
        check_scenario(path, **overrides)
    return info.value.problems
