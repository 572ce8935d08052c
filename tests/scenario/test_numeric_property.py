"""No number in a scenario can abort the process (issue 14): extreme values (subnormals,
zero and minus zero, 1e-300, 1e308, infinities, NaN, huge integers) put into one to three
numeric fields of a shipped scenario give a located error or a world whose observations
are finite and inside their spaces (and whose rewards are never NaN), every time.

Each example runs in a process of its own (``tests/isolated.py``), so an abort in C, a
hang or a runaway allocation fails the example instead of ending the test run. Examples
are derandomized (the default run replays exactly) and no example database is kept.
"""

from __future__ import annotations

import copy
import sys

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from flatland_ma.scenario.loader import read_raw
from tests.isolated import runner

HINGED_DOOR = {"kind": "hinged", "start": [150, 0], "end": [150, 60]}
RULES = [{"rule": "step_reward", "reward": -0.1}, {"rule": "contact_reward", "reward": -1}]
CAMERAS = [
    {"type": "camera", "name": "near", "rays": 16, "range": 50},
    {"type": "camera", "name": "around", "rays": 8, "fov": 360},
]
SUBJECTS = {
    # name: (shipped scenario, overrides that add what the fields need)
    "fruits_poisons": ("fruits_poisons", {}),
    "push_box": ("push_box", {}),
    "fetch_object": ("fetch_object", {}),
    "tug_of_war": ("tug_of_war", {}),
    "key_door": ("key_door", {}),
    "switch_door": ("switch_door", {}),
    "textured_fruits": ("textured_fruits", {}),
    "maze_goal": ("maze_goal", {}),
    "hinged_doors": ("hinged_doors", {}),
    "obstacle_forest": ("obstacle_forest", {}),
    "corridor_rooms": ("corridor_rooms", {}),
    "hinged_door": ("fruits_poisons", {"obstacles": [], "doors": [HINGED_DOOR]}),
    "rules": ("fruits_poisons", {"rules": RULES}),
    "cameras": ("fruits_poisons", {"agent": {"sensors": CAMERAS}}),
    **{
        f"{kind}_walls": ("fruits_poisons", {"arena": {"wall": {"texture": {"kind": kind}}}})
        for kind in ("checkers", "gradient", "noise", "stripes", "tiles")
    },
}
ARM = ("agent", "arms", 0)
SEGMENT = (*ARM, "segments", 0)
FIELDS = {
    "fruits_poisons": [
        ("n_agents",),
        ("physics", "dt"),
        ("physics", "substeps"),
        ("physics", "iterations"),
        ("episode", "max_steps"),
        ("arena", "size", 0),
        ("arena", "wall", "thickness"),
        ("obstacles", 0, "radius"),
        ("obstacles", 0, "position", 1),
        ("obstacles", 0, "friction"),
        ("obstacles", 1, "angle"),
        ("obstacles", 1, "size", 0),
        ("obstacles", 2, "vertices", 2, 1),
        ("obstacles", 3, "elasticity"),
        ("items", 0, "reward"),
        ("items", 0, "count"),
        ("items", 1, "radius"),
        ("agent", "radius"),
        ("agent", "mass"),
        ("agent", "max_speed"),
        ("agent", "max_turn_rate"),
        ("agent", "max_force"),
        ("agent", "max_torque"),
        ("agent", "camera", "rays"),
        ("agent", "camera", "fov"),
        ("agent", "camera", "range"),
        ("agent", "spawn", "heading"),
        ("agent", "head", "mass"),
        ("agent", "head", "offset"),
    ],
    "push_box": [
        ("obstacles", 0, "mass"),
        ("obstacles", 0, "floor_friction"),
        ("obstacles", 0, "size", 1),
        ("zones", 0, "rect", 2),
        ("zones", 0, "delivery_reward"),
        ("agent", "spawn", "area", 0),
    ],
    "fetch_object": [
        (*SEGMENT, "length"),
        (*SEGMENT, "width"),
        (*SEGMENT, "mass"),
        (*SEGMENT, "min_angle"),
        (*SEGMENT, "max_angle"),
        (*ARM, "mount"),
        (*ARM, "joint_rate"),
        (*ARM, "max_torque"),
        (*ARM, "grasper", "radius"),
        (*ARM, "grasper", "strength"),
        (*ARM, "grasper", "break_distance"),
        ("obstacles", 0, "mass"),
        ("obstacles", 0, "radius"),
    ],
    "tug_of_war": [
        ("agent", "head", "radius"),
        ("agent", "head", "offset"),
        ("agent", "head", "max_angle"),
        ("agent", "head", "turn_rate"),
        ("agent", "head", "max_torque"),
        ("agent", "head", "mass"),
        ("teams", 0, "size"),
        ("obstacles", 0, "mass"),
        ("zones", 0, "delivery_reward"),
    ],
    "key_door": [
        ("walls", 0, "thickness"),
        ("doors", 0, "start", 1),
        ("items", 0, "spawn", 2),
        ("items", 1, "positions", 0, 0),
        ("items", 0, "respawn"),
    ],
    "switch_door": [("zones", 0, "size", 0), ("zones", 0, "area", 3), ("doors", 0, "thickness")],
    "textured_fruits": [
        ("items", 0, "texture", "period"),
        ("items", 0, "texture", "duty"),
        ("items", 1, "texture", "period"),
        ("items", 1, "texture", "seed"),
    ],
    "maze_goal": [
        ("layout", "generators", 0, "cell"),
        ("layout", "generators", 0, "loops"),
        ("layout", "generators", 0, "thickness"),
    ],
    "hinged_doors": [
        ("layout", "generators", 0, "door_width"),
        ("layout", "generators", 0, "rows"),
        ("layout", "generators", 0, "cols"),
        ("layout", "seed"),
    ],
    "obstacle_forest": [
        ("layout", "generators", 0, "count"),
        ("layout", "generators", 0, "size", 1),
        ("layout", "generators", 0, "gap"),
    ],
    "corridor_rooms": [
        ("corridors", 0, "width"),
        ("corridors", 0, "end", 0),
        ("rooms", 0, "rect", 1),
        ("rooms", 0, "thickness"),
    ],
    "hinged_door": [
        ("doors", 0, "mass"),
        ("doors", 0, "swing"),
        ("doors", 0, "thickness"),
        ("doors", 0, "end", 1),
    ],
    "rules": [("rules", 0, "reward"), ("rules", 1, "reward")],
    "cameras": [
        ("agent", "sensors", 0, "rays"),
        ("agent", "sensors", 0, "range"),
        ("agent", "sensors", 1, "fov"),
    ],
    **{
        f"{kind}_walls": [
            ("arena", "wall", "texture", "period"),
            ("arena", "wall", "texture", "duty"),
            ("arena", "wall", "texture", "seed"),
        ]
        for kind in ("checkers", "gradient", "noise", "stripes", "tiles")
    },
}

EXTREMES = [0, 0.0, -0.0, 5e-324, -5e-324, 1e-310, sys.float_info.min, 1e-300, 1e-9, 0.1]
EXTREMES += [1, -1, 2.0, 1e6, 1e300, 1e308, -1e308, sys.float_info.max, -sys.float_info.max]
EXTREMES += [float("inf"), float("-inf"), float("nan"), 2**31, 2**53 + 1, 2**63, -(2**63)]
EXTREMES += [10**30]
EDGES = [0.001, 0.1, 0.5, 1.0, 3, 10, 32, 64, 100, 180, -180, 360, 720, 1000, 4096, 10_000]
EDGES += [20_000, 100_000, 1e6]
"""The limits of the plausible ranges, and values near them: mostly valid, they make
worlds at the edges of what the checks allow."""
VALUES = st.one_of(
    st.sampled_from(EXTREMES),
    st.sampled_from(EDGES),
    st.floats(min_value=5e-324, max_value=sys.float_info.min, allow_subnormal=True),
    st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True),
    st.integers(-(2**70), 2**70),
)
PROPERTY = settings(
    max_examples=100,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)
THOROUGH_EXAMPLES = 1500
"""Examples of the slow run (make test-slow); the default run tries 100."""


def data_of(subject: str) -> dict:
    """The subject's data as the loader reads it (extends followed), with its additions."""
    scenario, additions = SUBJECTS[subject]
    data, _ = read_raw(scenario)
    for key, value in additions.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **copy.deepcopy(value)}
        else:
            data[key] = copy.deepcopy(value)
    return data


def overrides_for(subject: str, values: dict[tuple, object]) -> dict:
    """Keyword overrides that set each key path of ``values`` in the subject: every
    top-level section they touch is given whole (lists are replaced whole by overrides),
    with the subject's additions."""
    data = data_of(subject)
    overrides = copy.deepcopy(SUBJECTS[subject][1])
    for path, value in values.items():
        top = path[0]
        if len(path) == 1:
            overrides[top] = value
            continue
        section = overrides.setdefault(top, copy.deepcopy(data.get(top, {})))
        node = section
        for key in path[1:-1]:
            if isinstance(node, dict):
                node = node.setdefault(key, {})
            else:
                node = node[key]
        node[path[-1]] = value
    return overrides


def test_every_field_exists_in_its_subject():
    """The key paths into lists name entries the subjects have (a typo would only make
    overrides that fail for an uninteresting reason)."""
    for subject, paths in FIELDS.items():
        data = data_of(subject)
        for path in paths:
            node = data
            for key in path[:-1]:
                if isinstance(key, int):
                    assert isinstance(node, list) and key < len(node), (subject, path)
                node = node[key] if isinstance(key, int) or key in node else {}


@st.composite
def cases(draw) -> tuple[str, dict]:
    subject = draw(st.sampled_from(sorted(FIELDS)))
    count = draw(st.integers(1, 3))
    paths = draw(st.permutations(FIELDS[subject]))[:count]
    return subject, {path: draw(VALUES) for path in paths}


@PROPERTY
@given(case=cases())
def test_extreme_numbers_give_a_located_error_or_a_finite_world(case):
    extreme_numbers_give_a_located_error_or_a_finite_world(case)


@pytest.mark.slow
@settings(PROPERTY, max_examples=THOROUGH_EXAMPLES)
@given(case=cases())
def test_extreme_numbers_give_a_located_error_or_a_finite_world_thoroughly(case):
    extreme_numbers_give_a_located_error_or_a_finite_world(case)


def extreme_numbers_give_a_located_error_or_a_finite_world(case):
    subject, values = case
    overrides = overrides_for(subject, values)
    outcome = runner().run(SUBJECTS[subject][0], overrides)
    report = f"{subject} with {values}: {outcome.summary()}"
    event(outcome.kind)  # pytest --hypothesis-show-statistics shows how many of each
    assert outcome.kind in ("works", "located"), report
    if outcome.kind == "works":
        assert outcome.finite and outcome.in_space and outcome.steps > 0, report
        # Rewards are numbers of the file, unbounded: their sums may overflow to inf
        # (tests/hostile: rewards_overflow.yaml), but never to NaN.
        assert not outcome.rewards_nan, report
    else:
        assert not outcome.unplaced(), report
