"""Scenario files: every shipped file validates; every fault is reported with the file,
the line and the key path; no malformed file reaches pymunk or numpy."""

import textwrap

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import flatland_ma
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import load_scenario, scenario_dir


def write(tmp_path, text, name="s.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def problems(path, **overrides):
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, **overrides)
    return info.value.problems


@pytest.mark.parametrize("name", flatland_ma.list_scenarios())
def test_every_shipped_scenario_validates_and_describes_itself(name):
    spec = load_scenario(name)
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


@pytest.mark.parametrize(
    "text, line, path, words",
    [
        ("n_agents: '2'\n", 1, ("n_agents",), "valid integer"),
        ("n_agents: 2.5\n", 1, ("n_agents",), "valid integer"),
        ("n_agents: 0\n", 1, ("n_agents",), "greater than or equal to 1"),
        ("episode:\n  max_steps: -5\n", 2, ("episode", "max_steps"), "greater than or equal to 1"),
        ("agent:\n  camera:\n    rays: many\n", 3, ("agent", "camera", "rays"), "valid integer"),
        (
            "agent:\n  camera:\n    fov: 400\n",
            3,
            ("agent", "camera", "fov"),
            "less than or equal to 360",
        ),
        ("agent:\n  actions: teleport\n", 2, ("agent", "actions"), "'discrete' or 'continuous'"),
        ("arena:\n  size: [300]\n", 2, ("arena", "size"), "too few items"),
        ("arena:\n  size: [300, .nan]\n", 2, ("arena", "size", 1), "finite"),
        (
            "arena:\n  wall:\n    color: oragne\n",
            3,
            ("arena", "wall", "color"),
            "unknown colour name 'oragne'",
        ),
        (
            "arena:\n  wall:\n    color: [300, 0, 0]\n",
            3,
            ("arena", "wall", "color"),
            "outside 0-255",
        ),
        (
            "items:\n  - {name: fruits, color: orange, reward: ten, count: 3}\n",
            2,
            ("items", 0, "reward"),
            "valid number",
        ),
        ("obstacles:\n  - {shape: star, position: [1, 1]}\n", 2, ("obstacles", 0), "'star'"),
        (
            "obstacles:\n  - shape: polygon\n    position: [50, 50]\n    vertices: [[0, 0], [10, 10], [10, 0], [0, 10]]\n",
            2,
            ("obstacles", 0),
            "convex",
        ),
        (
            "obstacles:\n  - {shape: circle, position: [5, 50], radius: 10}\n",
            2,
            ("obstacles", 0, "position"),
            "outside the 300 x 300 arena",
        ),
        (
            "obstacles:\n  - {shape: box, position: [100, 100], size: [40, 40]}\n  - {shape: circle, position: [120, 100], radius: 10}\n",
            3,
            ("obstacles", 1),
            "overlaps another obstacle",
        ),
        (
            "items:\n  - {name: fruits, color: orange, reward: 1, count: 5000, radius: 10}\n",
            2,
            ("items", 0, "count"),
            "no room",
        ),
        (
            "items:\n  - {name: a, color: red, reward: 1, count: 1}\n  - {name: a, color: red, reward: 1, count: 1}\n",
            3,
            ("items", 1, "name"),
            "used twice",
        ),
        ("n_agents: 60\nagent:\n  radius: 40\n", 1, ("n_agents",), "no room to place every agent"),
        # spawn areas outside the arena, or with no free room
        (
            "agent:\n  spawn: {area: [250, 250, 350, 350]}\n",
            2,
            ("agent", "spawn", "area"),
            "outside the 300 x 300 arena",
        ),
        (
            "items:\n  - {name: a, color: red, count: 2, spawn: [-10, 0, 50, 50]}\n",
            2,
            ("items", 0, "spawn"),
            "outside",
        ),
        (
            "zones:\n  - {size: [20, 20], area: [0, 0, 400, 50]}\n",
            2,
            ("zones", 0, "area"),
            "outside",
        ),
        ("zones:\n  - {rect: [0, 0, 20, 20], size: [5, 5]}\n", 2, ("zones", 0), "either a 'rect'"),
        ("rooms:\n  - {rect: [200, 200, 320, 280]}\n", 2, ("rooms", 0, "rect"), "outside"),
        ("rooms:\n  - {rect: [200, 200, 100, 280]}\n", 2, ("rooms", 0, "rect"), "x1 > x0"),
        (
            "obstacles:\n  - {shape: box, position: [150, 150], size: [280, 280]}\n",
            1,
            ("arena", "size"),
            "no free place where agents could start",
        ),
        (
            "obstacles:\n  - {shape: circle, position: [50, 150], radius: 10}\nwalls:\n  - {start: [50, 0], end: [50, 300]}\n",
            2,
            ("obstacles", 0),
            "overlaps a wall",
        ),
        # items nobody can reach
        (
            "walls:\n  - {start: [150, 0], end: [150, 300]}\nagent:\n  spawn: {area: [0, 0, 140, 300]}\nitems:\n  - {name: a, color: red, count: 1, spawn: [160, 0, 300, 300]}\n",
            6,
            ("items", 0, "spawn"),
            "no free place in the area that agents can reach",
        ),
        (
            "walls:\n  - {start: [150, 0], end: [150, 300]}\nagent:\n  spawn: {area: [0, 0, 140, 300]}\nitems:\n  - {name: a, color: red, positions: [[200, 150]]}\n",
            6,
            ("items", 0, "positions", 0),
            "agents cannot reach",
        ),
        # doors, keys, switches
        (
            "doors:\n  - {start: [150, 0], end: [150, 40], state: locked}\n",
            2,
            ("doors", 0),
            "needs a 'key' or a 'switch'",
        ),
        (
            "doors:\n  - {start: [150, 0], end: [150, 40], state: locked, key: gold}\n",
            2,
            ("doors", 0, "key"),
            "no key item group or key object 'gold'",
        ),
        (
            "doors:\n  - {start: [150, 0], end: [150, 40], switch: plate}\n",
            2,
            ("doors", 0, "switch"),
            "no zone named 'plate'",
        ),
        (
            "doors:\n  - {kind: hinged, key: k, start: [150, 0], end: [150, 40]}\n",
            2,
            ("doors", 0),
            "pushed open",
        ),
        ("doors:\n  - {state: closed}\n", 2, ("doors", 0), "needs 'start' and 'end'"),
        (
            "corridors:\n  - {start: [0, 0], end: [100, 100]}\n",
            2,
            ("corridors", 0),
            "horizontally or vertically",
        ),
        ("walls:\n  - {start: [10, 10], end: [10, 10]}\n", 2, ("walls", 0), "distinct"),
        (
            "walls:\n  - {start: [100, 10], end: [100, 200], thickness: 0.5}\nagent:\n  max_speed: 800\n",
            2,
            ("walls", 0, "thickness"),
            "can be crossed",
        ),
        ("items:\n  - {name: score, color: red}\n", 2, ("items", 0, "name"), "reserved"),
        (
            "episode:\n  end_when_eaten: gold\n",
            2,
            ("episode", "end_when_eaten"),
            "no item group 'gold'",
        ),
        (
            "layout:\n  generators:\n    - {generator: tunnels}\n",
            3,
            ("layout", "generators", 0),
            "'tunnels'",
        ),
        (
            "layout:\n  generators:\n    - {generator: maze, cel: 20}\n",
            3,
            ("layout", "generators", 0, "cel"),
            "did you mean 'cell'",
        ),
        (
            "layout:\n  generators:\n    - {generator: random_obstacles, count: 400, size: [40, 60]}\n",
            3,
            ("layout", "generators", 0, "count"),
            "could not place 400 obstacles",
        ),
        (
            "items:\n  - {name: a, color: red, texture: {kind: plaid}}\n",
            2,
            ("items", 0, "texture", "kind"),
            "'uniform'",
        ),
    ],
)
def test_faults_are_located(tmp_path, text, line, path, words):
    path_ = write(tmp_path, text)
    found = problems(path_)
    match = [p for p in found if p.path == path]
    assert match, f"no problem at {path}: {[str(p) for p in found]}"
    assert match[0].line == line and match[0].source == str(path_)
    assert words in match[0].message


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
    spec = load_scenario(child)
    base = load_scenario("fruits_poisons")
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
    spec = load_scenario("fruits_poisons", n_agents=2, agent={"camera": {"rays": 128}})
    assert spec.n_agents == 2 and spec.agent.camera.rays == 128 and spec.agent.camera.fov == 120
    spec = load_scenario("fruits_poisons", obstacles=[])
    assert spec.obstacles == ()
    with pytest.raises(ScenarioError) as info:
        load_scenario("fruits_poisons", agent={"camera": {"rays": "many"}})
    (p,) = info.value.problems
    assert p.source == "<overrides>" and p.line is None and p.path == ("agent", "camera", "rays")
    assert str(p).startswith("<overrides>: agent.camera.rays:")
    with pytest.raises(ScenarioError, match="unknown key 'n_agent'"):
        flatland_ma.parallel_env("fruits_poisons", n_agent=2)


def test_validate_command_reports_and_fails(tmp_path, capsys):
    from flatland_ma.cli import main

    good = write(tmp_path, "description: fine\n", "good.yaml")
    bad = write(tmp_path, "n_agents: x\n", "bad.yaml")
    assert main(["validate", str(good), "fruits_poisons"]) == 0
    assert main(["validate", str(good), str(bad)]) == 1
    out = capsys.readouterr().out
    assert f"{bad}:1: n_agents:" in out and "ok (1 agent(s)" in out


BASE = yaml.safe_load((scenario_dir() / "fruits_poisons.yaml").read_text())
SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
)
VALUES = st.recursive(
    SCALARS,
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4)
    ),
    max_leaves=12,
)
KEYS = st.sampled_from(
    [
        "n_agents",
        "episode",
        "physics",
        "arena",
        "obstacles",
        "items",
        "agent",
        "extends",
        "size",
        "camera",
        "rays",
        "radius",
        "shape",
        "position",
        "vertices",
        "color",
        "count",
        "bogus",
    ]
)


def _mutate(data, path, value):
    node = data
    for key in path[:-1]:
        if isinstance(node, dict):
            node = node.setdefault(key, {})
        elif isinstance(node, list) and node:
            node = node[hash(key) % len(node)]
        if not isinstance(node, (dict, list)):
            return data
    if isinstance(node, dict):
        node[path[-1]] = value
    elif isinstance(node, list) and node:
        node[hash(path[-1]) % len(node)] = value
    return data


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(path=st.lists(KEYS, min_size=1, max_size=4), value=VALUES)
def test_fuzzed_files_fail_only_with_scenario_errors(tmp_path, path, value):
    import copy

    data = _mutate(copy.deepcopy(BASE), path, value)
    file = tmp_path / "fuzz.yaml"
    file.write_text(yaml.safe_dump(data))
    try:
        env = flatland_ma.parallel_env(file)
    except ScenarioError as err:
        assert err.problems and all(p.source for p in err.problems)
        return
    env.reset(seed=0)
    env.step({a: env.action_space(a).sample() for a in env.agents})


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(cut=st.integers(0, 2000), junk=st.text(max_size=12))
def test_mangled_text_fails_only_with_scenario_errors(tmp_path, cut, junk):
    text = (scenario_dir() / "fruits_poisons.yaml").read_text()
    cut %= len(text)
    file = tmp_path / "mangled.yaml"
    file.write_text(text[:cut] + junk + text[cut:])
    try:
        load_scenario(file)
    except ScenarioError as err:
        assert err.problems


@pytest.mark.parametrize("document", ["README.md", "docs/scenarios.md"])
def test_the_yaml_examples_in_the_docs_are_valid_scenarios(tmp_path, document):
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parent.parent / document).read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", text, re.S)
    assert blocks
    for k, block in enumerate(blocks):
        path = tmp_path / f"example_{k}.yaml"
        path.write_text(block)
        env = flatland_ma.parallel_env(path)
        env.reset(seed=0)
        env.step({a: env.action_space(a).sample() for a in env.agents})
