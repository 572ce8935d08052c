"""Scenario files: every shipped file validates; every fault is reported with the file,
the line and the key path (malformed files are fuzzed in ``test_scenario_fuzz.py``)."""

import numpy as np
import pytest

import flatland_ma
from flatland_ma.build import capacity, feasibility, generators
from flatland_ma.build.feasibility import check_scenario
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import scenario_dir
from tests.scenario_helpers import problems, write


@pytest.mark.parametrize("name", flatland_ma.list_scenarios())
def test_every_shipped_scenario_validates_and_describes_itself(name):
    spec = check_scenario(name)
    assert spec.description
    text = (scenario_dir() / f"{name}.yaml").read_text()
    assert text.startswith("# "), "each file starts with a comment saying what the task is"


def test_unknown_key_names_file_line_path_and_suggests(tmp_path):
    path = write(
        tmp_path,
        """\
        description: test
        obstacles:
          - shape: circle
            position: [50, 50]
            radus: 10
        """,
    )
    (p,) = [p for p in problems(path) if "radus" in str(p)]
    assert p.source == str(path) and p.line == 5 and p.path == ("obstacles", 0, "radus")
    assert "unknown key 'radus'" in str(p) and "did you mean 'radius'" in str(p)
    assert str(p).startswith(f"{path}:5: obstacles[0].radus:")
    # ... and the missing radius is reported too, at the obstacle's line.
    assert any(
        q.path == ("obstacles", 0, "radius") and "missing" in q.message for q in problems(path)
    )


def test_yaml_syntax_errors_and_duplicate_keys(tmp_path):
    (p,) = problems(write(tmp_path, "n_agents: 1\narena: {size: [1, 2]\n"))
    assert "not valid YAML" in p.message and p.line == 3
    (p,) = problems(write(tmp_path, "n_agents: 1\nn_agents: 2\n"))
    assert p.line == 2 and "key given twice" in p.message
    (p,) = problems(write(tmp_path, "- 1\n- 2\n"))
    assert "mapping" in p.message
    (p,) = problems(write(tmp_path, "n_agents: !!python/object:os.system 1\n"))
    assert p.line == 1
    assert problems(write(tmp_path, "1: 2\n"))[0].message == "keys must be plain words"


def test_extends_merges_over_the_base_and_reports_the_right_file(tmp_path):
    child = write(tmp_path, "extends: fruits_poisons\nn_agents: 3\nagent:\n  camera: {rays: 16}\n")
    spec = check_scenario(child)
    base = check_scenario("fruits_poisons")
    assert spec.n_agents == 3 and spec.agent.camera.rays == 16
    assert spec.agent.camera.fov == base.agent.camera.fov and spec.obstacles == base.obstacles
    bad = write(tmp_path, "extends: fruits_poisons\nagent:\n  camera: {rays: -1}\n", "bad.yaml")
    (p,) = problems(bad)
    assert p.source == str(bad) and p.line == 3 and p.path == ("agent", "camera", "rays")
    (p,) = problems(write(tmp_path, "extends: nowhere\n", "orphan.yaml"))
    assert "unknown scenario 'nowhere'" in p.message and p.path == ("extends",)
    loop = write(tmp_path, f"extends: {tmp_path / 'loop.yaml'}\n", "loop.yaml")
    assert "cycle" in problems(loop)[0].message


def test_overrides_merge_like_a_file_and_are_validated_the_same_way():
    spec = check_scenario("fruits_poisons", n_agents=2, agent={"camera": {"rays": 128}})
    assert spec.n_agents == 2 and spec.agent.camera.rays == 128 and spec.agent.camera.fov == 120
    spec = check_scenario("fruits_poisons", obstacles=[])
    assert spec.obstacles == ()
    with pytest.raises(ScenarioError) as info:
        check_scenario("fruits_poisons", agent={"camera": {"rays": "many"}})
    (p,) = info.value.problems
    assert p.source == "<overrides>" and p.line is None and p.path == ("agent", "camera", "rays")
    assert str(p).startswith("<overrides>: agent.camera.rays:")
    with pytest.raises(ScenarioError, match="unexpected keyword argument 'n_agent'"):
        flatland_ma.parallel_env("fruits_poisons", n_agent=2)


def test_validate_command_reports_and_fails(tmp_path, capsys):
    from flatland_ma.cli import main

    good = write(tmp_path, "description: fine\n", "good.yaml")
    bad = write(tmp_path, "n_agents: x\n", "bad.yaml")
    assert main(["validate", str(good), "fruits_poisons"]) == 0
    assert main(["validate", str(good), str(bad)]) == 1
    out = capsys.readouterr().out
    assert f"{bad}:1: n_agents:" in out and "ok (1 agent(s)" in out


def test_doors_open_in_the_order_their_keys_can_be_reached(tmp_path):
    """Three rooms in a row behind two locked doors; each key must lie before its door."""
    arena = """\
arena: {size: [600, 250]}
walls:
  - {start: [200, 0], end: [200, 250]}
  - {start: [400, 0], end: [400, 250]}
doors:
  - {start: [200, 105], end: [200, 145], state: locked, key: first}
  - {start: [400, 105], end: [400, 145], state: locked, key: second}
agent:
  spawn: {area: [20, 20, 180, 230]}
items:
  - {name: first, color: gold, key: true, positions: [[FIRST, 60]]}
  - {name: second, color: gold, key: true, positions: [[SECOND, 60]]}
  - {name: goal, color: lime, positions: [[500, 125]]}
"""

    def keys_at(first, second):
        return arena.replace("FIRST", str(first)).replace("SECOND", str(second))

    assert check_scenario(write(tmp_path, keys_at(100, 300))).doors
    (p,) = problems(write(tmp_path, keys_at(300, 100)))
    assert p.path == ("items", 0, "positions", 0) and p.line == 11
    assert p.message == (
        "agents cannot reach this place (behind doors[0]: it never opens, nothing that "
        "opens it is reachable)"
    )


def test_an_obstacle_overlapping_a_wall_names_the_wall_too(tmp_path):
    with pytest.raises(ScenarioError) as info:
        check_scenario("fruits_poisons", walls=[{"start": [60, 0], "end": [60, 300]}])
    obstacle, wall = info.value.problems
    assert obstacle.path == ("obstacles", 0) and "overlaps a wall (walls[0])" in obstacle.message
    assert wall.source == "<overrides>" and wall.path == ("walls", 0)
    assert wall.message == "overlaps obstacles[0]"


def test_a_union_field_gives_one_message(tmp_path):
    (p,) = problems(write(tmp_path, "items:\n  - {name: a, color: red, respawn: 0}\n"))
    assert p.path == ("items", 0, "respawn") and p.line == 2
    assert (
        p.message == "Input should be 'immediate' or 'never', or greater than or equal to 1; got 0"
    )


def test_an_unknown_key_in_an_optional_section_lists_that_sections_keys(tmp_path):
    (p,) = problems(write(tmp_path, "agent:\n  head:\n    radios: 3\n"))
    assert p.path == ("agent", "head", "radios") and p.line == 3
    assert "did you mean 'radius'" in p.message and "max_angle" in p.message


def test_numpy_numbers_are_accepted_as_overrides():
    spec = check_scenario("fruits_poisons", n_agents=np.int64(2), agent={"radius": np.float32(8.0)})
    assert spec.n_agents == 2 and type(spec.n_agents) is int and spec.agent.radius == 8.0
    spec = check_scenario("fruits_poisons", arena={"size": np.array([320.0, 300.0])})
    assert spec.arena.size == (320.0, 300.0)


def test_the_validate_summary_counts_items_at_fixed_places(tmp_path, capsys):
    from flatland_ma.cli import main

    path = write(
        tmp_path, "items:\n  - {name: a, color: red, positions: [[50, 50], [90, 50], [130, 50]]}\n"
    )
    assert main(["validate", str(path)]) == 0
    assert "3 items)" in capsys.readouterr().out


def test_random_obstacles_cut_off_no_team_from_its_spawn_area(monkeypatch):
    starts = []

    def recording(gen, world, grid, start, *rest):
        starts.append((grid, start))
        return scatter(gen, world, grid, start, *rest)

    scatter = generators.scatter_obstacles
    monkeypatch.setattr(generators, "scatter_obstacles", recording)
    layout = {"generators": [{"generator": "random_obstacles", "count": 3}]}
    # Nobody starts in agent.spawn (each team has its own area): only the teams' count.
    spec = check_scenario("tug_of_war", layout=layout, agent={"spawn": {"area": [240, 0, 260, 20]}})
    grid, start = starts[0]
    for team in spec.teams:
        assert start[grid.cells_in(team.spawn.area)].all()
    assert not (start & grid.cells_in(spec.agent.spawn.area)).any()


def test_a_placement_that_fails_at_reset_names_the_file_and_key(tmp_path, monkeypatch):
    """Loading checks a few seeds with room to spare; with those checks loosened, a reset
    that finds no room raises a located ScenarioError, not a bare error from the builder."""
    monkeypatch.setattr(capacity, "MAX_COVER", 1.0)
    monkeypatch.setattr(feasibility, "CHECK_SEEDS", 1)
    text = "extends: fruits_poisons\nitems:\n  - {name: a, color: red, radius: 10, count: 100}\n"
    env = flatland_ma.parallel_env(write(tmp_path, text))
    failures = []
    for seed in range(1, 20):
        try:
            env.reset(seed=seed)
        except ScenarioError as err:
            failures += err.problems
    assert failures, "expected some seed to run out of room"
    p = failures[0]
    assert p.source == str(tmp_path / "s.yaml") and p.line == 3
    assert p.path == ("items", 0, "count") and "no room to place every item" in p.message


@pytest.mark.parametrize("document", ["README.md", "docs/scenarios.md"])
def test_the_yaml_examples_in_the_docs_are_valid_scenarios(tmp_path, document):
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / document).read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", text, re.S)
    assert blocks
    for k, block in enumerate(blocks):
        path = tmp_path / f"example_{k}.yaml"
        path.write_text(block)
        env = flatland_ma.parallel_env(path)
        env.reset(seed=0)
        env.step({a: env.action_space(a).sample() for a in env.agents})
