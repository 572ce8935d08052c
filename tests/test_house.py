"""The house's seams: layers import downward, loading builds nothing, and sensors, rules,
parts and generators plug in through one interface each; and its rooms: no module loose
at the package's top, no import circle, no file or function past its size, no reads of
another module's private members (``tests/house_rules.py`` counts them all:
``python -m tests.house_rules``)."""

import ast
import math
from pathlib import Path

import numpy as np
import pymunk
import pytest
from pettingzoo.test import parallel_api_test

import flatland_ma
from flatland_ma.agents.actuators import Actuator
from flatland_ma.agents.grasp import Grasper
from flatland_ma.agents.parts import PART_KINDS, ArmSegment, Control, Head, Part
from flatland_ma.build import feasibility
from flatland_ma.build.bodies import make_parts
from flatland_ma.build.generators import GENERATOR_KINDS
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.sensors.sensor import SENSOR_KINDS
from flatland_ma.tasks.rule import RULE_KINDS
from flatland_ma.world.entities import HingedDoor, Item, SlidingDoor
from tests import house_rules
from tests.world_helpers import place, walk

PACKAGE = Path(__file__).resolve().parent.parent / "flatland_ma"

FORBIDDEN = {
    "scenario": ["world", "agents", "sensors", "tasks", "envs", "build", "render", "policies"],
    "world": ["scenario", "build", "tasks", "agents", "sensors", "envs", "render", "policies"],
    "sensors": ["scenario", "build", "tasks", "agents", "envs", "render", "policies"],
    "agents": ["scenario", "build", "tasks", "envs", "render", "policies"],
    "tasks": ["scenario", "sensors", "build", "envs", "render", "policies"],
    "build": ["envs", "render", "policies"],
    "envs": ["policies", "evaluation", "lifelong"],
    "policies": ["evaluation", "lifelong"],
    "evaluation": ["lifelong"],
}
for _layer in ("scenario", "world", "sensors", "agents", "tasks", "build"):
    FORBIDDEN[_layer] += ["evaluation", "lifelong"]
FORBIDDEN.update({"render": [], "play": [], "integrations": []})
for _layer in FORBIDDEN:  # the top floors: the studio uses the rest, adapters serve clients
    FORBIDDEN[_layer] += ["studio"] + (["integrations"] if _layer != "integrations" else [])
"""What each layer may not import: only the layers below it (the file format is at the
bottom and apart: only build/ and what is above it read specs)."""

BRIDGE = "flatland_ma/world/physics.py"
"""The one module that reaches past pymunk's documented API."""


def imports_of(path: Path) -> list[tuple[int, str]]:
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            found.append((node.lineno, node.module))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
    return found


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_layers_import_only_downward(layer):
    files = sorted((PACKAGE / layer).rglob("*.py"))
    assert files
    wrong = [
        f"{path.relative_to(PACKAGE)}:{line} imports {module}"
        for path in files
        for line, module in imports_of(path)
        for other in FORBIDDEN[layer]
        if module == f"flatland_ma.{other}" or module.startswith(f"flatland_ma.{other}.")
    ]
    assert wrong == []


def runtime_imports(path: Path) -> set[str]:
    """The modules (and names, as ``module.name``) a file imports when it runs, anywhere
    in it, leaving out imports made for the type checker alone."""
    tree = ast.parse(path.read_text())
    typing_only = {
        id(inner)
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
        for statement in node.body
        for inner in ast.walk(statement)
    }
    found = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found |= {node.module} | {f"{node.module}.{alias.name}" for alias in node.names}
        elif isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
    return found


def test_no_two_modules_import_each_other_even_lazily():
    """A loop of imports, even through an import inside a function, means two files that
    are one; the package's root (which every import passes through) is left out."""
    modules = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    graph = {
        module: {
            m for m in runtime_imports(path) if m in modules and m not in (module, "flatland_ma")
        }
        for module, path in modules.items()
    }
    loops = []
    for start in graph:  # a loop through ``start``: a path from one of its imports back to it
        seen, frontier = set(), [(m, [start, m]) for m in graph[start]]
        while frontier:
            module, path = frontier.pop()
            if module == start:
                loops.append(" -> ".join(path))
                break
            if module not in seen:
                seen.add(module)
                frontier += [(m, [*path, m]) for m in graph[module]]
    assert loops == []


def test_nothing_but_the_door_at_the_package_top():
    """Every module lives in the subpackage of its layer; ``flatland_ma/__init__.py``
    alone stands at the top."""
    assert house_rules.top_level_modules() == ["__init__.py"]


def test_every_subpackage_is_a_layer_and_no_import_goes_up():
    """Each subpackage has its floor (``house_rules.LAYERS``) and imports only the floors
    beneath it, wherever the import is (in a function, for the type checker alone)."""
    assert house_rules.unplaced() == []
    assert house_rules.up_imports() == []


def test_no_import_circle_in_the_package():
    """No two modules of flatland_ma need each other: not through imports made when they
    load, nor through the type checker's, nor through those inside functions."""
    for graph in house_rules.import_graphs():
        inside = {
            module: {m for m in imported if m.startswith("flatland_ma")}
            for module, imported in graph.items()
            if module.startswith("flatland_ma")
        }
        assert house_rules.circles(inside) == []


def test_the_checker_finds_a_circle_and_an_import_up():
    """The rules above can fail: a circle of three, and a sensor that reads the file format."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert house_rules.circles(graph) == [["a", "b", "c"]]
    assert not house_rules.may_import("sensors", "scenario")
    assert not house_rules.may_import("world", "envs")
    assert house_rules.may_import("build", "scenario") and house_rules.may_import(
        "scenario", "kinds"
    )


def test_only_the_physics_bridge_touches_pymunk_internals():
    """``world/physics.py`` is the one bridge to pymunk beyond its documented API."""
    touching = [row.split(":")[0] for row in house_rules.pymunk_internals()]
    assert touching == [BRIDGE]


def test_no_library_file_is_over_400_lines():
    assert house_rules.long_files_and_functions()[0] == []


def test_no_function_is_over_60_lines():
    assert house_rules.long_files_and_functions()[1] == []


def test_no_module_reads_another_modules_private_members():
    """None but the bridge's reads of pymunk's own members, which the rule above holds to
    that one file."""
    outside = [row for row in house_rules.private_reads() if not row.startswith(BRIDGE)]
    assert outside == []


def test_loading_every_scenario_builds_no_space(monkeypatch):
    made = []
    original = pymunk.Space.__init__

    def counting(self, *args, **kwargs):
        made.append(self)
        original(self, *args, **kwargs)

    monkeypatch.setattr(pymunk.Space, "__init__", counting)
    for name in flatland_ma.list_scenarios():
        flatland_ma.load_scenario(name)
    assert made == []
    flatland_ma.check_scenario("fruits_poisons", description="new")  # the checks do build
    assert made


def test_a_scenario_that_passed_is_not_checked_again(monkeypatch):
    calls = []
    monkeypatch.setattr(feasibility, "check_layout", calls.append)
    flatland_ma.check_scenario("maze_goal", description="once")
    flatland_ma.parallel_env("maze_goal", description="once")
    assert len(calls) == 1
    flatland_ma.check_scenario("maze_goal", description="twice")  # other contents: checked
    assert len(calls) == 2


def test_several_sensors_give_a_dict_observed_in_one_kernel_call():
    sensors = [
        {"type": "camera", "name": "front", "rays": 32},
        {"type": "camera", "name": "wide", "rays": 8, "fov": 300, "range": 100},
    ]
    env = flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors})
    space = env.observation_space("agent_0")
    assert set(space.spaces) == {"front", "wide"}
    assert space["front"].shape == (32, 4) and space["wide"].shape == (8, 4)
    observations, _ = env.reset(seed=0)
    suite = env.episode.sensors
    assert suite.image.shape == (4 * (32 + 8), 4)  # every ray of every agent in one image
    for agent, observation in observations.items():
        assert env.observation_space(agent).contains(observation)
    # The wide camera sees no farther than its range: depth 1 means nothing within 100.
    first = suite.per_agent[0][1]
    assert (suite.distance[suite.slices[first]] <= 100.0 + 1e-9).all()
    parallel_api_test(flatland_ma.parallel_env("fruits_poisons_multi", agent={"sensors": sensors}))


def test_sensor_names_must_differ():
    with pytest.raises(ScenarioError, match="two sensors are called 'camera'"):
        flatland_ma.load_scenario("fruits_poisons", agent={"sensors": [{"type": "camera"}] * 2})
    with pytest.raises(ScenarioError, match="mounted on the head needs a 'head'"):
        flatland_ma.load_scenario(
            "fruits_poisons", agent={"sensors": [{"type": "camera", "mount": "head"}]}
        )


def test_every_kind_is_found_by_name():
    assert SENSOR_KINDS["camera"].__name__ == "Camera"
    assert RULE_KINDS["step_reward"].__name__ == "StepReward"
    assert RULE_KINDS["contact_reward"].__name__ == "ContactReward"
    assert GENERATOR_KINDS["maze"].__name__ == "Maze"
    assert PART_KINDS["grasper"] is Grasper
    with pytest.raises(KeyError, match="no sensor of kind 'sonar'; known kinds: camera"):
        SENSOR_KINDS["sonar"]


def test_a_step_reward_rule_adds_to_every_step():
    env = flatland_ma.parallel_env(
        "fruits_poisons", items=[], obstacles=[], rules=[{"rule": "step_reward", "reward": -0.5}]
    )
    env.reset(seed=0)
    total, infos = walk(env, 10, action=1)  # turning in place: nothing else rewards
    assert total == pytest.approx(-5.0) and infos["agent_0"]["score"] == pytest.approx(-5.0)


def test_a_contact_reward_rule_rewards_only_steps_in_contact():
    rules = [{"rule": "contact_reward", "reward": -1.0}]
    env = flatland_ma.parallel_env("fruits_poisons", items=[], obstacles=[], rules=rules)
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, 0.0)
    free, _ = walk(env, 5, action=1)
    assert free == 0.0
    place(env, 0, 300.0 - 10.5, 150.0, 0.0)  # against the east wall, facing it
    bumped, _ = walk(env, 5, action=0)
    assert bumped == pytest.approx(-5.0)


def test_rules_apply_in_the_documented_order():
    env = flatland_ma.parallel_env("fruits_poisons", rules=[{"rule": "step_reward", "reward": 1}])
    env.reset(seed=0)
    kinds = [type(rule).__name__ for rule in env.episode.task.rules]
    assert kinds == [
        "ItemRule",
        "ZoneRule",
        "DoorRule",
        "DeliveryRule",
        "StepReward",
        "EndingRule",
    ]


def test_the_camera_sees_an_item_moved_through_the_world_without_any_sync():
    env = flatland_ma.parallel_env("fruits_poisons", obstacles=[])
    env.reset(seed=0)
    place(env, 0, 150.0, 150.0, 0.0)
    item = next(e for e in env.episode.world.entities if isinstance(e, Item))
    env.episode.world.move_static(item, 200.0, 150.0)  # straight ahead, 50 away
    env.episode.sensors.observe()
    sensors = env.episode.sensors
    middle = sensors.slices[0].start + 32
    assert sensors.hit_entity[middle] == item.index
    assert sensors.distance[middle] == pytest.approx(50.0 - item.radius, abs=0.5)
    env.episode.world.withdraw(item)
    env.episode.sensors.observe()
    assert sensors.hit_entity[middle] != item.index


def test_door_kinds_answer_how_they_open():
    door = SlidingDoor(body=None, shapes=(), color=(0, 0, 0), locked=True, key_name="gold")
    assert not door.opens_to_touch(set()) and door.opens_to_touch({"gold"})
    assert door.opens_to_key("gold") and not door.opens_to_key("iron")
    assert door.needs_opener and door.blocks(set()) and not door.blocks({"gold"})
    closed = SlidingDoor(body=None, shapes=(), color=(0, 0, 0))
    assert closed.opens_to_touch(set()) and not closed.needs_opener
    switched = SlidingDoor(body=None, shapes=(), color=(0, 0, 0), switch_zone="plate")
    assert not switched.opens_to_touch({"gold"}) and switched.needs_opener
    hinged = HingedDoor(body=pymunk.Body(), shapes=(), color=(0, 0, 0), swing=1.0)
    assert hinged.swings and not hinged.opens_to_touch(set()) and not hinged.needs_opener
    hinged.body.angle = 0.5
    assert hinged.blocks(set())  # swung aside, it stands in the way


def test_parts_make_the_action_layout():
    spec = flatland_ma.load_scenario("tug_of_war").agent
    parts = make_parts(spec)
    assert [type(p) for p in parts] == [Head, ArmSegment, Grasper]
    discrete = Actuator("discrete", parts)
    assert discrete.names == (
        "forward",
        "rotate_left",
        "rotate_right",
        "stay",
        "head_left",
        "head_right",
        "arm_left",
        "arm_right",
        "grasp",
        "release",
    )
    continuous = Actuator("continuous", parts)
    assert continuous.names == ("longitudinal", "lateral", "angular", "head", "arm", "arm_grip")
    # Reach: the arm's tip is the base's radius, the segment and the grasper away.
    arm = spec.arms[0]
    tip = spec.radius + arm.segments[0].length + arm.grasper.radius
    assert max(p.reach() for p in parts) == pytest.approx(tip)


def test_two_arms_name_their_joints_and_hands():
    arm = {"segments": [{"length": 10}, {"length": 8}]}
    spec = flatland_ma.load_scenario("fetch_object", agent={"arms": [arm, {"mount": 90}]}).agent
    names = Actuator("continuous", make_parts(spec)).names
    assert names[3:] == ("arm0_joint0", "arm0_joint1", "arm1_joint0", "arm0_grip", "arm1_grip")
    macros = Actuator("discrete", make_parts(spec)).names
    assert "arm0_grasp" in macros and "arm1_release" in macros and "grasp" not in macros


def test_generators_run_in_file_order():
    gens = [
        {"generator": "grid_rooms", "rows": 2, "cols": 2},
        {"generator": "random_obstacles", "count": 2, "gap": 30},
    ]
    for order in (gens, gens[::-1]):
        env = flatland_ma.parallel_env("fruits_poisons", obstacles=[], layout={"generators": order})
        env.reset(seed=3)
        kinds = [type(e).__name__ for e in env.episode.world.entities[1:]]
        kinds = [k for k in kinds if k in ("Wall", "Obstacle")]
        first = "Wall" if order[0]["generator"] == "grid_rooms" else "Obstacle"
        assert kinds[0] == first and len(set(kinds)) == 2
        # Whatever the order, nothing overlaps: each generator works over what stands.
        space = env.episode.world.space
        for entity in env.episode.world.entities:
            if type(entity).__name__ == "Obstacle":
                hits = [h for s in entity.shapes for h in space.shape_query(s)]
                assert all(h.shape.sensor or h.shape.body is not space.static_body for h in hits)


def test_a_zone_entry_is_logged_once_per_entry():
    env = flatland_ma.parallel_env("explore_goal")
    env.reset(seed=0)
    (zone,) = env.episode.world.zones
    x0, y0, x1, y1 = zone.rect
    place(env, 0, x0 - 15.0, (y0 + y1) / 2, 0.0)
    entries = 0
    for _ in range(12):
        env.step({"agent_0": 0})
        entries += sum(z is zone for _, z in env.episode.world.log.entered)
    assert entries == 1
    assert math.isclose(env.episode.task.records[0].score, zone.reward) or zone.once
    assert np.isfinite(env.episode.task.records[0].score)


class Beacon(Part):
    """A test part with no body: a lamp an agent switches on and off (one control)."""

    def __init__(self):
        self.controls = (Control("beacon", "beacon_on", "beacon_off"),)
        self.label, self.on = "beacon", False

    @classmethod
    def for_agent(cls, agent):
        return [cls()] if agent.max_speed == 123.0 else []

    def build(self, agent):
        agent.beacon = self
        return None

    def command(self, values, angles):
        (value,) = values
        if value is not None:
            self.on = value > 0

    def reach(self):
        return 0.0

    def top_speed(self, base_speed, base_turn):
        return base_speed

    def half_width(self):
        return 0.0


def test_a_new_part_kind_plugs_in_through_the_registry(monkeypatch):
    monkeypatch.setitem(PART_KINDS, "beacon", Beacon)
    plain = flatland_ma.parallel_env("fruits_poisons")
    assert plain.action_space("agent_0").n == 3  # only agents that declare it have it
    env = flatland_ma.parallel_env("fruits_poisons", agent={"max_speed": 123.0})
    assert env.action_names() == (
        "forward",
        "rotate_left",
        "rotate_right",
        "stay",
        "beacon_on",
        "beacon_off",
    )
    env.reset(seed=0)
    lamp = env.episode.bodies[0].beacon
    env.step({"agent_0": env.action_index("beacon_on")})
    assert lamp.on
    env.step({"agent_0": env.action_index("forward")})  # other actions leave it alone
    assert lamp.on
    env.step({"agent_0": env.action_index("beacon_off")})
    assert not lamp.on
