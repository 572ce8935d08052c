"""Every number that reaches pymunk or the ray kernel has a physically plausible range:
the values that once aborted the process, stalled it or poisoned observations are refused
with a located error, and worlds at the limits run with finite observations."""

import math

import numpy as np
import pytest

import flatland_ma
from tests.scenario_helpers import problems, write

TINY, SUBNORMAL, HUGE = 1e-300, 5e-324, 1e300

ARM = {"segments": [{"length": 16}], "grasper": None}
REFUSED = [
    # (overrides, key path of the fault)
    (
        {"agent": {"arms": [{"segments": [{"length": TINY}]}]}},
        ("agent", "arms", 0, "segments", 0, "length"),
    ),
    (
        {"agent": {"arms": [{"segments": [{"width": TINY}]}]}},
        ("agent", "arms", 0, "segments", 0, "width"),
    ),
    ({"agent": {"mass": TINY}}, ("agent", "mass")),
    ({"agent": {"mass": SUBNORMAL}}, ("agent", "mass")),
    ({"agent": {"mass": HUGE}}, ("agent", "mass")),
    ({"agent": {"head": {"mass": TINY}}}, ("agent", "head", "mass")),
    ({"agent": {"max_speed": HUGE}}, ("agent", "max_speed")),
    (
        {"doors": [{"start": [150, 0], "end": [150, 40], "kind": "hinged", "mass": HUGE}]},
        ("doors", 0, "mass"),
    ),
    (
        {
            "obstacles": [
                {
                    "shape": "circle",
                    "radius": 5,
                    "position": [50, 50],
                    "movable": True,
                    "mass": SUBNORMAL,
                }
            ]
        },
        ("obstacles", 0, "mass"),
    ),
    (
        {"obstacles": [{"shape": "circle", "radius": TINY, "position": [50, 50]}]},
        ("obstacles", 0, "radius"),
    ),
    (
        {"obstacles": [{"shape": "box", "size": [10, TINY], "position": [50, 50]}]},
        ("obstacles", 0, "size", 1),
    ),
    (
        {"obstacles": [{"shape": "circle", "radius": 5, "position": [50, 50], "friction": HUGE}]},
        ("obstacles", 0, "friction"),
    ),
    ({"physics": {"dt": TINY}}, ("physics", "dt")),
    ({"physics": {"dt": 100.0}}, ("physics", "dt")),
    ({"arena": {"wall": {"thickness": TINY}}}, ("arena", "wall", "thickness")),
    (
        {"arena": {"wall": {"texture": {"kind": "checkers", "period": TINY}}}},
        ("arena", "wall", "texture", "period"),
    ),
    (
        {"arena": {"wall": {"texture": {"kind": "noise", "period": SUBNORMAL}}}},
        ("arena", "wall", "texture", "period"),
    ),
    (
        {"arena": {"wall": {"texture": {"kind": "gradient", "period": SUBNORMAL}}}},
        ("arena", "wall", "texture", "period"),
    ),
    ({"agent": {"camera": {"range": TINY}}}, ("agent", "camera", "range")),
    ({"items": [{"name": "dot", "color": "red", "radius": TINY}]}, ("items", 0, "radius")),
    ({"walls": [{"start": [150, 10], "end": [150, 10 + 1e-10]}]}, ("walls", 0)),
    (
        {"doors": [{"start": [150, 0], "end": [150, TINY], "kind": "hinged"}]},
        ("doors", 0),
    ),
    ({"corridors": [{"start": [100, 100], "end": [100, 100 + 1e-7]}]}, ("corridors", 0)),
    ({"rooms": [{"rect": [100, 100, 100 + 1e-5, 200]}]}, ("rooms", 0, "rect")),
    ({"zones": [{"rect": [100, 100, 200, 100.01]}]}, ("zones", 0, "rect")),
    ({"items": [{"name": "dot", "color": "red", "reward": HUGE}]}, ("items", 0, "reward")),
    ({"rules": [{"rule": "step_reward", "reward": -HUGE}]}, ("rules", 0, "reward")),
    (
        {"zones": [{"rect": [10, 10, 50, 50], "delivery_reward": 2e6}]},
        ("zones", 0, "delivery_reward"),
    ),
]


@pytest.mark.parametrize("overrides, path", REFUSED, ids=[str(p) for _, p in REFUSED])
def test_implausible_numbers_get_a_located_error(tmp_path, overrides, path):
    text = "extends: fruits_poisons\nobstacles: []\n"
    found = problems(write(tmp_path, text), **overrides)
    assert found[0].path == path and found[0].source == "<overrides>"
    message = found[0].message
    assert "greater than" in message or "less than" in message or "at least" in message


AT_THE_LIMITS = {
    "physics": {"dt": 0.001},
    "agent": {
        "mass": 0.001,
        "radius": 5.0,
        "arms": [{"segments": [{"length": 0.1, "width": 0.1, "mass": 0.001}], "grasper": None}],
        "head": {"radius": 0.1, "offset": 0.0, "mass": 0.001},
    },
    "arena": {"wall": {"texture": {"kind": "gradient", "period": 0.1}}},
}


def test_a_world_at_the_limits_runs_with_finite_observations():
    env = flatland_ma.parallel_env("fruits_poisons", **AT_THE_LIMITS)
    env.reset(seed=0)
    space = env.action_space("agent_0")
    space.seed(0)
    for _ in range(200):
        observations, rewards, *_ = env.step({"agent_0": space.sample()})
        assert np.isfinite(observations["agent_0"]).all()
        assert env.observation_space("agent_0").contains(observations["agent_0"])
        assert np.isfinite(rewards["agent_0"])
    for body in env.episode.world.space.bodies:
        assert np.isfinite([*body.position, body.angle, *body.velocity]).all()


STAR = [
    [
        round(10 * math.cos(math.pi / 2 + k * 4 * math.pi / 5), 6),
        round(10 * math.sin(math.pi / 2 + k * 4 * math.pi / 5), 6),
    ]
    for k in range(5)
]
BAD_POLYGONS = [
    (STAR, "winds 2 times around, not once"),
    ([[0, 0], [10, 0], [0, 10]] * 2, "vertices 0 and 3 are at the same place"),
    ([[0, 0], [10, 0], [5, 0.01]], "0.01 thick at its thinnest, less than 0.1"),
    ([[0, 0], [10, 0], [10, 0], [0, 10]], "vertices 1 and 2 are at the same place"),
]


@pytest.mark.parametrize("vertices, message", BAD_POLYGONS)
def test_stars_twice_wound_slivers_and_repeated_vertices_are_not_convex_polygons(
    tmp_path, vertices, message
):
    obstacle = {"shape": "polygon", "position": [50, 50], "vertices": vertices}
    (problem,) = problems(write(tmp_path, "obstacles: []\n"), obstacles=[obstacle])
    assert problem.path == ("obstacles", 0) and message in problem.message


def test_a_grid_rooms_opening_wider_than_its_wall_is_refused(tmp_path):
    gen = {"generator": "grid_rooms", "rows": 3, "cols": 3, "door_width": 95, "thickness": 8}
    (problem,) = problems(write(tmp_path, "obstacles: []\n"), layout={"generators": [gen]})
    assert problem.path == ("layout", "generators", 0, "door_width")
    assert "do not fit in walls 100 long" in problem.message
    gen["door_width"] = 80  # 80 + 2 x 8 fits in 100
    flatland_ma.parallel_env(write(tmp_path, "obstacles: []\n"), layout={"generators": [gen]})


def test_every_union_tag_is_dropped_from_key_paths():
    """Each discriminated union of the format names its tag key in ``TAG_KEYS``, so that an
    error inside a rule, a generator or an obstacle is located at the file's own keys."""
    import pathlib
    import re

    from flatland_ma.scenario import messages

    source = pathlib.Path(messages.__file__).parent
    tags = set()
    for path in source.glob("*.py"):
        tags |= set(re.findall(r'discriminator="([a-z_]+)"', path.read_text()))
    assert tags and tags <= set(messages.TAG_KEYS)
