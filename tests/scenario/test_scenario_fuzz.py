"""Malformed scenario files: whatever a file says, loading it either works (and the env then
resets and steps) or raises ``ScenarioError`` naming the file and, for a fault at a key,
the line and the key path. No other exception, from pymunk, numpy, PyYAML or anywhere.

The property tests mutate the data of every shipped scenario at any key path, and mangle
the raw text of every shipped file; examples are derandomized (they replay exactly) and
no example database is kept. The regressions below them pin faults the fuzzing found.
"""

from __future__ import annotations

import copy
import math
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import flatland_ma
from flatland_ma.build import feasibility
from flatland_ma.build.feasibility import check_scenario
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import scenario_dir
from flatland_ma.world.navigation import MAX_CELLS, NavGrid

NAMES = flatland_ma.list_scenarios()
FILES = {name: scenario_dir() / f"{name}.yaml" for name in NAMES}
TEXTS = {name: path.read_bytes() for name, path in FILES.items()}
DATA = {name: yaml.safe_load(text) for name, text in TEXTS.items()}
FUZZ = settings(
    max_examples=200,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

# -- values ------------------------------------------------------------------------------

EDGE_NUMBERS = [0, -1, 1, 2, 0.5, -0.5, 1e-9, 1e-300, -1e-300, 1e6, 1e300, -1e300, 1.7e308]
EDGE_NUMBERS += [math.nan, math.inf, -math.inf, 2**31, 2**63, -(2**63), 10**40]
WORDS = ["red", "circle", "box", "polygon", "maze", "grid_rooms", "random_obstacles"]
WORDS += ["locked", "closed", "open", "hinged", "key", "plate", "goal", "never", "head"]
NUMBERS = st.one_of(
    st.sampled_from(EDGE_NUMBERS),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
)
SCALARS = st.one_of(st.none(), st.booleans(), NUMBERS, st.text(max_size=8), st.sampled_from(WORDS))
KEYS = st.one_of(st.text(max_size=6), st.sampled_from(["bogus", "radius", "start", "spawn"]))
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(KEYS, inner, max_size=4),
    max_leaves=10,
)
SCALES = [-1.0, 0.0, 1e-6, 0.5, 2.0, 10.0, 1e6, 1e300]


def nested(depth: int):
    value: object = 1
    for _ in range(depth):
        value = [value]
    return value


# -- data mutations ----------------------------------------------------------------------


def key_paths(node, prefix=()) -> list[tuple]:
    """Every key path in the data: mapping keys and list indices, at any depth."""
    paths = []
    children = node.items() if isinstance(node, dict) else enumerate(node)
    for key, child in children:
        paths.append(prefix + (key,))
        if isinstance(child, (dict, list)) and child:
            paths += key_paths(child, prefix + (key,))
    return paths


def get(doc, path):
    for key in path:
        doc = doc[key]
    return doc


SECTIONS = sorted({key for data in DATA.values() for key in data})


OPS = ["set", "set", "delete", "unknown", "scale", "scale", "scale", "graft", "graft", "share"]
"""Mutations, the ones that keep more files valid (to run, not only load) more often."""


def mutate(data, doc: dict) -> None:
    """Apply one random mutation to ``doc`` in place."""
    paths = key_paths(doc)
    op = data.draw(st.sampled_from(OPS))
    if op == "graft" or not paths:
        # A section of another shipped scenario: walls, rooms, doors, zones, teams, ...
        donor = DATA[data.draw(st.sampled_from(NAMES))]
        key = data.draw(st.sampled_from(sorted(donor)))
        doc[key] = copy.deepcopy(donor[key])
        return
    path = data.draw(st.sampled_from(paths))
    parent, last = get(doc, path[:-1]), path[-1]
    if op == "set":
        parent[last] = data.draw(st.one_of(VALUES, st.sampled_from([nested(31), nested(40)])))
    elif op == "delete":
        del parent[last]
    elif op == "unknown":
        target = get(doc, path)
        if isinstance(target, dict):
            target[data.draw(KEYS)] = data.draw(SCALARS)
        else:
            parent[last] = {data.draw(KEYS): target}
    elif op == "scale":
        numbers = [p for p in paths if type(get(doc, p)) in (int, float)]
        if numbers:
            where = data.draw(st.sampled_from(numbers))
            value = get(doc, where) * data.draw(st.sampled_from(SCALES))
            get(doc, where[:-1])[where[-1]] = value
    else:  # share: one subtree in two places, written as a YAML anchor and an alias
        source = data.draw(st.sampled_from(paths))
        if path[: len(source)] != source:  # not into itself
            parent[last] = get(doc, source)


# -- text mangling -----------------------------------------------------------------------

SNIPPETS = [b"&a ", b"*a", b"<<: *a\n", b"!!python/object:os.system ", b"\t", b"\x00"]
SNIPPETS += [b"\xff\xfe", b"[", b"{", b"]", b"}", b": ", b"- ", b"? ", b"|\n", b"%YAML 1.1\n"]
SNIPPETS += [
    b"r: &r [*r]\n",
    b"---\n",
    b"...\n",
    b"!!binary ",
    b"!!int x ",
    b"!!float ",
    b"1e400",
    b".nan",
]
SNIPPETS += [b"~", b"'", b'"', b"#", "\ufeff".encode(), b"\n  ", b"\n\t", b"extends: maze_goal\n"]
LAUGHS = b"l0: &l0 [x, x, x, x, x, x, x, x, x]\n" + b"".join(
    b"l%d: &l%d [" % (k, k) + b", ".join([b"*l%d" % (k - 1)] * 9) + b"]\n" for k in range(1, 9)
)


def mangle(data, text: bytes) -> bytes:
    op = data.draw(st.sampled_from(["insert", "bytes", "delete", "deep", "laughs", "tabs"]))
    at = data.draw(st.integers(0, len(text)))
    if op == "insert":
        return text[:at] + data.draw(st.sampled_from(SNIPPETS)) + text[at:]
    if op == "bytes":
        return text[:at] + data.draw(st.binary(min_size=1, max_size=6)) + text[at:]
    if op == "delete":
        return text[:at] + text[at + data.draw(st.integers(1, 40)) :]
    if op == "deep":
        depth = data.draw(st.sampled_from([31, 33, 100, 5000]))
        return text + b"deep: " + b"[" * depth + b"]" * depth + b"\n"
    if op == "laughs":
        return text + LAUGHS
    return text.replace(b"  ", b"\t", data.draw(st.integers(1, 3)))


# -- the property ------------------------------------------------------------------------


def load_and_run(path: Path) -> None:
    """Load ``path``: it must work and run a few steps, or fail with a good ScenarioError."""
    try:
        env = flatland_ma.parallel_env(path)
    except ScenarioError as err:
        assert err.problems
        known = {str(path), *map(str, FILES.values())}
        for problem in err.problems:
            assert problem.source in known, str(problem)
            assert problem.message and "internal error" not in problem.message, str(problem)
            if problem.path:
                assert problem.line is not None, str(problem)
            assert str(problem).startswith(problem.source)
        return
    env.reset(seed=0)
    for i, agent in enumerate(env.possible_agents):
        env.action_space(agent).seed(i)
    for _ in range(3):
        if not env.agents:
            break
        env.step({a: env.action_space(a).sample() for a in env.agents})


THOROUGH_MUTATED, THOROUGH_MANGLED = 600, 400
"""Examples of the slow runs (make test-slow); the default run tries a third of them."""


@FUZZ
@given(data=st.data())
def test_mutated_scenario_data_fails_only_with_located_errors(data):
    mutated_data_fails_only_with_located_errors(data)


@pytest.mark.slow
@settings(FUZZ, max_examples=THOROUGH_MUTATED)
@given(data=st.data())
def test_mutated_scenario_data_fails_only_with_located_errors_thoroughly(data):
    mutated_data_fails_only_with_located_errors(data)


def mutated_data_fails_only_with_located_errors(data):
    name = data.draw(st.sampled_from(NAMES))
    doc = copy.deepcopy(DATA[name])
    for _ in range(data.draw(st.integers(1, 3))):
        mutate(data, doc)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fuzz.yaml"
        path.write_text(yaml.safe_dump(doc))
        load_and_run(path)


@settings(FUZZ, max_examples=130)
@given(data=st.data())
def test_mangled_scenario_text_fails_only_with_located_errors(data):
    mangled_text_fails_only_with_located_errors(data)


@pytest.mark.slow
@settings(FUZZ, max_examples=THOROUGH_MANGLED)
@given(data=st.data())
def test_mangled_scenario_text_fails_only_with_located_errors_thoroughly(data):
    mangled_text_fails_only_with_located_errors(data)


def mangled_text_fails_only_with_located_errors(data):
    text = TEXTS[data.draw(st.sampled_from(NAMES))]
    for _ in range(data.draw(st.integers(1, 3))):
        text = mangle(data, text)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "mangled.yaml"
        path.write_bytes(text)
        load_and_run(path)


# -- regressions -------------------------------------------------------------------------


def fault(tmp_path, text: str):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        check_scenario(path)
    (problem, *_) = info.value.problems
    assert problem.source == str(path)
    return problem


@pytest.mark.parametrize(
    "text, key, words",
    [
        ("walls:\n  - {start: [1.0e+300, 0], end: [1.0e+300, 100]}\n", "walls[0].start", "outside"),
        ("doors:\n  - {start: [100, 0], end: [100, -1.0e+300]}\n", "doors[0].end", "outside"),
        (
            "corridors:\n  - {start: [10, 1.0e+300], end: [90, 1.0e+300]}\n",
            "corridors[0].start",
            "outside",
        ),
        (
            "corridors:\n  - {start: [10, 150], end: [90, 150], width: 400}\n",
            "corridors[0].width",
            "outside",
        ),
        (
            "walls:\n  - {start: [0, 0], end: [100, 0], thickness: 1.0e+300}\n",
            "walls[0].thickness",
            "less than or equal to 10000",
        ),
        ("arena: {size: [100000000, 100000000]}\n", "arena.size[0]", "less than or equal to 10000"),
        (
            "layout: {generators: [{generator: maze, cell: 0.5}]}\n",
            "layout.generators[0].cell",
            "work budget",
        ),
        (
            "layout: {generators: [{generator: maze, cell: 25}]}\n",
            "layout.generators[0].cell",
            "cannot pass",
        ),
        ("n_agents: !!int abc\n", "n_agents", "bad value"),
    ],
)
def test_out_of_bounds_input_is_located(tmp_path, text, key, words):
    problem = fault(tmp_path, text)
    assert str(problem).startswith(f"{problem.source}:") and f": {key}: " in str(problem)
    assert words in problem.message


def test_walls_may_end_on_the_boundary_walls(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("walls:\n  - {start: [150, -5], end: [150, 305]}\n")
    assert check_scenario(path).walls[0].end == (150, 305)


def test_deep_nesting_and_alias_bombs_are_refused_quickly(tmp_path):
    problem = fault(tmp_path, "n_agents: 1\nx: " + "[" * 5000 + "]" * 5000 + "\n")
    assert problem.line == 2 and "nested more than 32 levels deep" in problem.message
    problem = fault(tmp_path, LAUGHS.decode())
    assert "expands to more than 100,000 values" in problem.message


def test_an_unexpected_exception_still_names_the_file(tmp_path, monkeypatch):
    def broken(spec):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(feasibility, "check_layout", broken)
    path = tmp_path / "s.yaml"
    path.write_text("n_agents: 2\n")
    with pytest.raises(ScenarioError) as info:
        check_scenario(path)
    (problem,) = info.value.problems
    assert problem.source == str(path) and "internal error" in problem.message
    assert isinstance(info.value.__cause__, ZeroDivisionError)  # the bug is not hidden


def test_the_navigation_grid_stays_small_on_the_largest_arena():
    grid = NavGrid((10_000.0, 10_000.0), clearance=0.01)
    assert grid.blocked.size <= MAX_CELLS and grid.cell >= 5.0
