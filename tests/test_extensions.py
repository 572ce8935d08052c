"""Extensions from a package outside the repository: a sensor, a rule, a part and a
generator, registered by a call and by entry points, named in a scenario file, validated
with located errors and in the JSON schema; and the seams they go through (a sensor spec
without ``mount``, a part's link registered by the protocol, proprioception sized from the
parts it is given). The README's Extending section states the files counted here."""

import json
import math
import re
import subprocess
import sys
from pathlib import Path
from typing import Literal

import pymunk
import pytest

import flatland_ma
from flatland_ma.agents.parts import PART_KINDS, Control, Jointed, jointed_link
from flatland_ma.kinds.registry import ExtensionError
from flatland_ma.scenario.extensions import register
from flatland_ma.scenario.spec_sensors import CameraSpec, SensorBaseSpec
from flatland_ma.sensors.sensor import SENSOR_KINDS, Sensor

ROOT = Path(__file__).resolve().parent.parent
ENTRY_POINT = "my_world = my_world:register"
"""The one line of the package's pyproject.toml that declares its kinds."""

PACKAGE = {
    "pyproject.toml": f"""\
[project]
name = "my-world"
version = "0.1"
dependencies = ["flatland-ma"]

[project.entry-points."flatland_ma.extensions"]
{ENTRY_POINT}
""",
    "my_world/__init__.py": '''\
"""my_world: a sensor, a rule, a part and a generator for flatland_ma."""


def register():
    """Make this package's kinds known to flatland_ma (its entry point calls this)."""
    import flatland_ma

    from my_world.antenna import Antenna, AntennaSpec
    from my_world.compass import Compass, CompassSpec
    from my_world.fence import Fence, FenceSpec
    from my_world.moving import MovingReward, MovingRewardSpec

    flatland_ma.register(CompassSpec, Compass)
    flatland_ma.register(MovingRewardSpec, MovingReward)
    flatland_ma.register(AntennaSpec, Antenna)
    flatland_ma.register(FenceSpec, Fence)
''',
    "my_world/compass.py": '''\
"""A compass: where a fixed bearing lies from the agent's heading."""

import math
from typing import Annotated, Literal

import numpy as np
from gymnasium import spaces
from pydantic import Field

from flatland_ma.scenario.spec_sensors import SensorBaseSpec
from flatland_ma.sensors.sensor import Sensor


class CompassSpec(SensorBaseSpec):
    """A compass: the cosine and sine of a bearing seen from the agent's heading."""

    type: Literal["compass"]
    """Selects this sensor."""
    bearing: Annotated[float, Field(strict=True, ge=-180, le=180)] = 90.0
    """The bearing it points to, in degrees counter-clockwise from +x."""


class Compass(Sensor):
    def __init__(self, name="compass", bearing=90.0):
        self.name = name
        self.bearing = math.radians(bearing)
        self.space = spaces.Box(-1.0, 1.0, (2,), np.float32)

    def read(self, results, k):
        body = results.carriers[k].actor.body  # the agent's base
        turn = self.bearing - body.angle
        return np.array([math.cos(turn), math.sin(turn)], np.float32)
''',
    "my_world/moving.py": '''\
"""A rule: a reward for every step an agent moves."""

from typing import Annotated, Literal

from pydantic import Field

from flatland_ma.scenario.spec_rules import RuleBaseSpec
from flatland_ma.tasks.rule import Rule


class MovingRewardSpec(RuleBaseSpec):
    """A reward to an agent for each step its base moves at least ``min_speed``."""

    rule: Literal["moving_reward"]
    """Selects this rule."""
    reward: Annotated[float, Field(strict=True, ge=-10, le=10)]
    """Reward per step of moving."""
    min_speed: Annotated[float, Field(strict=True, ge=0)] = 20.0
    """The slowest speed that counts as moving, units per second."""


class MovingReward(Rule):
    def __init__(self, reward, min_speed=20.0):
        self.reward, self.min_speed = reward, min_speed

    def reset(self, ctx):
        self.bodies = ctx.bodies
        self.steps = [0] * len(ctx.bodies)

    def apply(self, step):
        for i in step.live:
            if self.bodies[i].body.velocity.length >= self.min_speed:
                step.rewards[i] += self.reward
                self.steps[i] += 1

    def info(self, agent, out):
        out["moving_steps"] = self.steps[agent]
''',
    "my_world/antenna.py": '''\
"""A part: an antenna on the back of the base, which the agent swings."""

import math
from typing import Annotated, Literal

import pymunk
from pydantic import Field

from flatland_ma.agents.parts import Control, Jointed, jointed_link
from flatland_ma.scenario.spec_agent import PartBaseSpec


class AntennaSpec(PartBaseSpec):
    """A rod on the back of the base, on a motorised joint."""

    type: Literal["antenna"]
    """Selects this part."""
    length: Annotated[float, Field(strict=True, gt=0, le=30)] = 10.0
    """Its length from the base's rim."""
    max_angle: Annotated[float, Field(strict=True, gt=0, le=90)] = 60.0
    """How far it swings either way from straight back, in degrees."""


class Antenna(Jointed):
    """Its one control swings it (``antenna_left`` / ``antenna_right``)."""

    def __init__(self, base_radius, length=10.0, max_angle=60.0):
        self.base_radius, self.length = base_radius, length
        self.limits = (math.pi - math.radians(max_angle), math.pi + math.radians(max_angle))
        self.rate = math.radians(90.0)
        self.controls = (Control("antenna", "antenna_left", "antenna_right"),)

    @classmethod
    def from_spec(cls, values, agent):
        return cls(base_radius=agent.radius, **values)

    def build(self, agent):
        base = agent.body
        verts = [(0.0, -2.0), (self.length, -2.0), (self.length, 2.0), (0.0, 2.0)]
        body = pymunk.Body(0.05, pymunk.moment_for_poly(0.05, verts))
        body.center_of_gravity = (self.length / 2, 0.0)
        body.angle = base.angle + math.pi
        body.position = base.local_to_world((-self.base_radius, 0.0))
        shape = pymunk.Poly(body, verts)
        self.link = jointed_link(
            agent, body, (shape,), base, body.position, self.limits, self.rate, 10_000.0
        )
        return self.link

    def reach(self):
        return self.base_radius + self.length

    def top_speed(self, base_speed, base_turn):
        return base_speed + (base_turn + self.rate) * self.reach()

    def half_width(self):
        return 2.0
''',
    "my_world/fence.py": '''\
"""A generator: a fence across the arena at a random height, with one gap."""

from typing import Literal

from flatland_ma.build.generators import Generator
from flatland_ma.build.layout import Layout, WallPiece
from flatland_ma.scenario.spec_world import GeneratorBaseSpec
from flatland_ma.scenario.types import Length


class FenceSpec(GeneratorBaseSpec):
    """A wall across the arena, between 30% and 70% of its height, with one gap."""

    generator: Literal["fence"]
    """Selects this generator."""
    gap: Length = 50.0
    """Width of the gap, at a random place along the fence."""


class Fence(Generator):
    def generate(self, ground, rng):
        width, height = self.scenario.arena.size
        wall = self.scenario.arena.wall
        y = float(rng.uniform(0.3, 0.7)) * height
        x = float(rng.uniform(self.spec.gap, width - self.spec.gap))
        pieces = [
            WallPiece((a, y), (b, y), wall.thickness, wall.color, None, self.path)
            for a, b in ((0.0, x - self.spec.gap / 2), (x + self.spec.gap / 2, width))
        ]
        ground.add(Layout(pieces, []))
''',
    "world.yaml": """\
# my_world: a fenced room; agents with a compass and an antenna, paid to keep moving.
description: "A room cut by a fence with a gap; a compass, an antenna, a moving reward."
n_agents: 2
arena: {size: [300, 300]}
layout:
  generators:
    - {generator: fence, gap: 60}
agent:
  sensors:
    - {type: camera, rays: 16}
    - {type: compass, bearing: 90}
    - {type: proprioception}
  parts:
    - {type: antenna, length: 10}
rules:
  - {rule: moving_reward, reward: 0.01}
episode: {max_steps: 40}
""",
}
"""What a user writes, as it would be on disk: paths from the package's root."""

FILES_PER_KIND = {
    "sensor": ["my_world/compass.py"],
    "rule": ["my_world/moving.py"],
    "part": ["my_world/antenna.py"],
    "generator": ["my_world/fence.py"],
    "scenario": ["world.yaml"],
}
"""The files each kind takes: its class and its spec in one module (a scenario: its file)."""
ONCE = ["pyproject.toml", "my_world/__init__.py"]
"""Written once per package: the entry point, and the function registering every kind."""

CHECK = r"""
import json, sys
from pathlib import Path

import jsonschema
from pettingzoo.test import parallel_api_test

import flatland_ma
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.json_schema import file_schema
from flatland_ma.world.entities import Wall

home = Path(sys.argv[1])
if sys.argv[2] == "call":
    import my_world

    my_world.register()
world = str(home / "world.yaml")
found = {"spec": flatland_ma.load_scenario(world).agent.parts[0].model_dump()}
env = flatland_ma.parallel_env(world)
space = env.observation_space("agent_0")
found["spaces"] = {k: list(s.shape) for k, s in space.spaces.items()}
found["actions"] = list(env.action_names())
obs, _ = env.reset(seed=0)
found["fence"] = [
    [round(s.bb.left), round(s.bb.right)]
    for e in env.episode.world.entities
    if isinstance(e, Wall)
    for s in e.shapes
    if 0.3 * 300 - 6 < s.bb.bottom and s.bb.top < 0.7 * 300 + 6
]
joints, total = [], 0.0
for t in range(20):
    act = env.action_index("forward" if t < 10 else "antenna_left")
    obs, rewards, _, _, infos = env.step({a: act for a in env.agents})
    assert all(space.contains(o) for o in obs.values()), obs
    joints.append(float(obs["agent_0"]["proprioception"][3]))
    total += rewards["agent_0"]
found.update(joints=joints, total=total, moving=infos["agent_0"]["moving_steps"])
found["compass"] = [float(v) for v in obs["agent_0"]["compass"]]
parallel_api_test(flatland_ma.parallel_env(world), num_cycles=30)
bad = home / "bad.yaml"
bad.write_text(
    "extends: world.yaml\n"
    "agent:\n"
    "  sensors:\n"
    "    - {type: compass, bearing: 400}\n"
    "  parts:\n"
    "    - {type: antenna, lenght: 5}\n"
    "rules:\n"
    "  - {rule: moving_rewad, reward: 1}\n"
)
try:
    flatland_ma.load_scenario(bad)
    found["problems"] = []
except ScenarioError as err:
    found["problems"] = [[p.line, list(p.path), p.message] for p in err.problems]
schema = file_schema()
found["defs"] = sorted(schema["$defs"])
checker = jsonschema.Draft202012Validator(schema)
import yaml

found["schema_takes_world"] = checker.is_valid(yaml.safe_load((home / "world.yaml").read_text()))
wrong = yaml.safe_load((home / "world.yaml").read_text())
wrong["agent"]["parts"][0]["lenght"] = 5
found["schema_rejects_bad_key"] = not checker.is_valid(wrong)
print(json.dumps(found))
"""
"""Run in a fresh process (the registries are per process): the package's kinds from a
scenario file, through an env, PettingZoo's API test, a faulty file and the JSON schema."""


def write_package(home: Path) -> None:
    for name, text in PACKAGE.items():
        path = home / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def run_check(home: Path, how: str, paths: list[Path]) -> dict:
    env = {"PYTHONPATH": ":".join(str(p) for p in paths), "PATH": "/usr/bin:/bin"}
    done = subprocess.run(
        [sys.executable, "-c", CHECK, str(home), how],
        capture_output=True,
        text=True,
        env=env,
        timeout=900,  # a kill for a hung run only: it takes seconds
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def check_found(found: dict) -> None:
    assert found["spec"] == {"length": 10.0, "max_angle": 60.0, "type": "antenna"}
    assert found["spaces"] == {"camera": [16, 4], "compass": [2], "proprioception": [4]}
    assert found["actions"][-2:] == ["antenna_left", "antenna_right"]
    (_, gap_start), (gap_end, _) = sorted(found["fence"])  # two pieces, a gap between
    assert gap_end - gap_start == pytest.approx(60, abs=2)
    # The antenna's joint, read by proprioception, swings once it is commanded.
    assert found["joints"][9] == pytest.approx(0.0, abs=0.05) and found["joints"][-1] > 0.3
    assert found["moving"] >= 5 and found["total"] == pytest.approx(0.01 * found["moving"])
    assert math.hypot(*found["compass"]) == pytest.approx(1.0, abs=1e-5)
    problems = {tuple(path): (line, message) for line, path, message in found["problems"]}
    assert set(problems) == {
        ("agent", "sensors", 0, "bearing"),
        ("agent", "parts", 0, "lenght"),
        ("rules", 0),
    }
    assert problems[("agent", "sensors", 0, "bearing")][0] == 4
    assert "less than or equal to 180" in problems[("agent", "sensors", 0, "bearing")][1]
    assert problems[("agent", "parts", 0, "lenght")][0] == 6
    assert "did you mean 'length'" in problems[("agent", "parts", 0, "lenght")][1]
    assert problems[("rules", 0)][0] == 8
    assert "did you mean 'moving_reward'" in problems[("rules", 0)][1]
    assert {"CompassSpec", "MovingRewardSpec", "AntennaSpec", "FenceSpec"} <= set(found["defs"])
    assert found["schema_takes_world"] and found["schema_rejects_bad_key"]


def test_a_package_outside_the_repository_registers_its_kinds_by_a_call(tmp_path):
    write_package(tmp_path)
    check_found(run_check(tmp_path, "call", [tmp_path]))


def test_an_installed_package_registers_its_kinds_by_entry_points(tmp_path):
    """The package's entry point as pip would install it (a ``.dist-info`` beside it on
    the path); nothing imports the package but flatland_ma, when a file names a kind."""
    write_package(tmp_path)
    info = tmp_path / "my_world-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-world\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[flatland_ma.extensions]\n{ENTRY_POINT}\n")
    check_found(run_check(tmp_path, "entry", [tmp_path]))


def test_the_readme_states_the_files_each_kind_takes():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Extending", 1)[1].split("\n## ", 1)[0]
    stated = {
        kind: int(count)
        for kind, count in re.findall(r"\*\*An? (\w+)\*\*.*?Files you write: (\d+)", section, re.S)
    }
    assert stated == {kind: len(files) for kind, files in FILES_PER_KIND.items()}
    once = re.search(r"Once per package: (\d+) files", section)
    assert once and int(once.group(1)) == len(ONCE)
    assert sorted(PACKAGE) == sorted(ONCE + [f for fs in FILES_PER_KIND.values() for f in fs])
    calls = PACKAGE["my_world/__init__.py"].count("flatland_ma.register(")
    assert calls == len(FILES_PER_KIND) - 1  # one line per kind (a scenario needs none)


class Whisker(Jointed):
    """A test part of a new kind on a joint, made for agents whose ``max_speed`` is 123."""

    def __init__(self):
        self.controls = (Control("whisker", "whisker_left", "whisker_right"),)
        self.label = "whisker"

    @classmethod
    def for_agent(cls, agent):
        return [cls()] if agent.max_speed == 123.0 else []

    def build(self, agent):
        body = pymunk.Body(0.05, pymunk.moment_for_circle(0.05, 0, 2.0))
        body.angle, body.position = agent.body.angle, agent.body.position
        shape = pymunk.Circle(body, 2.0, (8.0, 0.0))
        limits = (-1.0, 1.0)
        self.link = jointed_link(agent, body, (shape,), agent.body, body.position, limits, 3.0, 1e4)
        return self.link

    def reach(self):
        return 10.0

    def top_speed(self, base_speed, base_turn):
        return base_speed + (base_turn + 3.0) * 10.0

    def half_width(self):
        return 2.0


def test_proprioception_sizes_itself_from_a_new_part_kind(monkeypatch):
    """It declared Box(-1, 1, (3,)) beside any part of a new kind, and read a joint the
    space did not have once the part's link was on the agent."""
    monkeypatch.setitem(PART_KINDS, "whisker", Whisker)
    sensors = [{"type": "proprioception"}]
    env = flatland_ma.parallel_env("fruits_poisons", agent={"max_speed": 123.0, "sensors": sensors})
    assert env.observation_space("agent_0").shape == (4,)
    obs, _ = env.reset(seed=0)
    assert env.episode.bodies[0].links == [env.episode.bodies[0].parts[0].link]
    for _ in range(15):
        obs, *_ = env.step({"agent_0": env.action_index("whisker_left")})
        assert env.observation_space("agent_0").contains(obs["agent_0"])
    assert obs["agent_0"][3] > 0.5  # the joint turned towards its upper limit


class Broken(Whisker):
    """Says it is not jointed, yet its ``build`` returns a link."""

    jointed = False


def test_a_part_whose_build_breaks_its_word_is_named(monkeypatch):
    monkeypatch.setitem(PART_KINDS, "whisker", Broken)
    with pytest.raises(ExtensionError, match="Broken.build must return no Link"):
        flatland_ma.parallel_env("fruits_poisons", agent={"max_speed": 123.0})


def test_a_sensor_spec_without_a_mount_sits_on_the_base():
    class Bare(SensorBaseSpec):
        type: str = "bare"

    assert Bare().mounted_on == "base" and CameraSpec(mount="head").mounted_on == "head"
    assert Sensor.mount == "base"


def test_register_refuses_what_would_change_a_shipped_kind():
    class Dial(Sensor):
        def read(self, results, k):
            return None

    class CameraAgain(SensorBaseSpec):
        type: Literal["camera"]

    with pytest.raises(ValueError, match="kind 'camera' exists already"):
        register(CameraAgain, Dial)
    with pytest.raises(TypeError, match="no sensor, rule, part or generator"):
        register(CameraAgain, int)
    with pytest.raises(TypeError, match="subclass of SensorBaseSpec"):
        register(SensorBaseSpec, Dial)
    assert SENSOR_KINDS["camera"].__name__ == "Camera"
