"""The hostile corpus: scenario files meant to hang, exhaust or abort the process, each
with the outcome expected of it.

Every file in this folder has one row here, and some rows write their file at test time
(big files, and files that must name their own absolute path). ``tests/test_hostile.py``
runs each row in a process of its own (``tests/isolated.py``) and checks its outcome:

- ``works``: the scenario loads, resets and steps, with finite observations inside their
  spaces;
- ``located``: ``ScenarioError`` whose problems each name their file (and, for a fault at a
  key, its line); the problem at ``key`` (the key path as printed, ``""`` for the whole
  file, None for any problem) has each of ``words`` in its message;
- ``bounded``: either of the two (with finite rewards too, if it works), for legal but
  huge files that the package may run or refuse as too much work, as long as it answers
  within the time limit.

Rows with ``pending`` or ``bug`` are expected to fail until the package changes (strict
xfail): ``pending`` names work in progress, ``bug`` a fault this corpus found.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

FOLDER = Path(__file__).resolve().parent

WORKS, LOCATED, BOUNDED = "works", "located", "bounded"
TIME_LIMIT = 20.0
"""Seconds a case may take by default: any file is answered within it."""
HEAVY_TIME_LIMIT = 30.0
"""Seconds for the largest legal files (thousands of walls, doors, obstacles), which run
only in ``make test-slow``; those that pass take at most half of it on an idle machine."""


@dataclass(frozen=True)
class Case:
    """One hostile input and the outcome expected of it."""

    name: str
    """The file in this folder, or the name of the one ``make`` writes."""
    expect: str
    key: str | None = None
    """For ``located``: the key path of the expected problem, as ``str(problem)`` prints
    it (``""``: a problem with the whole file); None: any problem."""
    words: tuple[str, ...] = ()
    """For ``located``: words the expected problem's message contains."""
    source: str | None = None
    """For ``located``: a regular expression the problem's source matches (searched);
    None: the case's own file."""
    make: Callable[[Path], Path] | None = None
    """Writes the case's file(s) into a folder and returns the file to load."""
    time_limit: float = TIME_LIMIT
    steps: int = 10
    """Random steps after each of the two resets."""
    slow: bool = False
    """Only in ``make test-slow`` (seconds of work, or long on purpose)."""
    pending: str = ""
    bug: str = ""

    def path(self, folder: Path) -> Path:
        """The file to load: this folder's, or the one ``make`` writes into ``folder``."""
        return self.make(folder) if self.make else FOLDER / self.name


def works(name: str, **options) -> Case:
    return Case(name, WORKS, **options)


def located(name: str, key: str | None, *words: str, **options) -> Case:
    return Case(name, LOCATED, key, words, **options)


def bounded(name: str, **options) -> Case:
    return Case(name, BOUNDED, **options)


# -- files written at test time ------------------------------------------------------------


def written(name: str, text: Callable[[], str]) -> Callable[[Path], Path]:
    def make(folder: Path) -> Path:
        path = folder / name
        path.write_text(text())
        return path

    return make


def grid(k: int, step: float = 100.0) -> tuple[float, float]:
    """The lower-left corner of the k-th cell of a 100 x 100 grid over a 10,000 arena."""
    return step * (k % 100), step * (k // 100)


def listing(section: str, count: int, entry: Callable[[int], str], head: str = "") -> str:
    """A file with a 10,000 x 10,000 arena and ``count`` entries in ``section``."""
    lines = [f"  - {entry(k)}\n" for k in range(count)]
    return f"arena: {{size: [10000, 10000]}}\n{head}{section}:\n" + "".join(lines)


def circle(k: int) -> str:
    x, y = grid(k)
    return f"{{shape: circle, position: [{x + 50:g}, {y + 50:g}], radius: 5}}"


def wall(k: int, kind: str = "") -> str:
    x, y = grid(k)
    return f"{{{kind}start: [{x + 20:g}, {y + 20:g}], end: [{x + 60:g}, {y + 20:g}], thickness: 2}}"


def two_walls(k: int) -> str:
    """The k-th of two walls in each cell: a horizontal one, then a vertical one."""
    x, y = grid(k // 2)
    if k % 2 == 0:
        return f"{{start: [{x + 20:g}, {y + 20:g}], end: [{x + 60:g}, {y + 20:g}], thickness: 2}}"
    return f"{{start: [{x + 80:g}, {y + 30:g}], end: [{x + 80:g}, {y + 70:g}], thickness: 2}}"


def closed_room(k: int) -> str:
    x, y = grid(k)
    return f"{{rect: [{x + 20:g}, {y + 20:g}, {x + 80:g}, {y + 80:g}], thickness: 2}}"


def zone(k: int) -> str:
    x, y = grid(k)
    return f"{{rect: [{x + 20:g}, {y + 20:g}, {x + 60:g}, {y + 60:g}], reward: 1}}"


def room(k: int) -> str:
    x, y = grid(k)
    rect = f"[{x + 20:g}, {y + 20:g}, {x + 80:g}, {y + 80:g}]"
    return f"{{rect: {rect}, thickness: 2, openings: [{{side: north, width: 30}}]}}"


def item_positions(count: int) -> str:
    places = ", ".join(f"[{x + 50:g}, {y + 50:g}]" for x, y in map(grid, range(count)))
    return f"items:\n  - {{name: fruits, color: orange, positions: [{places}]}}\n"


def sensors(count: int) -> str:
    cameras = "".join(
        f"    - {{type: camera, name: c{k}, rays: 4096, fov: 360, range: 20000}}\n"
        for k in range(count)
    )
    head = "n_agents: 64\narena: {size: [10000, 10000]}\nagent:\n  radius: 5\n  sensors:\n"
    return head + cameras


def extends_self(folder: Path) -> Path:
    path = folder / "extends_self.yaml"
    path.write_text(f"extends: {path}\n")
    return path


def extends_cycle(folder: Path) -> Path:
    first, second = folder / "cycle_a.yaml", folder / "cycle_b.yaml"
    first.write_text(f"extends: {second}\n")
    second.write_text(f"n_agents: 2\nextends: {first}\n")
    return first


def extends_chain(depth: int) -> Callable[[Path], Path]:
    """``depth`` files, each extending the next, the last one a shipped scenario."""

    def make(folder: Path) -> Path:
        files = [folder / f"chain_{k}.yaml" for k in range(depth)]
        bases = [str(path) for path in files[1:]] + ["fruits_poisons"]
        for path, base in zip(files, bases):
            path.write_text(f"extends: {base}\ndescription: {path.stem}\n")
        return files[0]

    return make


# -- the table -----------------------------------------------------------------------------

YAML = [
    works("empty.yaml"),  # every key has a default
    works("only_comments.yaml"),
    works("utf8_bom.yaml"),
    works("control_chars_description.yaml"),
    located("broken_flow.yaml", "", "not valid YAML"),
    located("tab_indent.yaml", "", "not valid YAML", "'\\t'"),
    located("top_level_list.yaml", "", "the file must be a mapping of keys"),
    located("top_level_scalar.yaml", "", "the file must be a mapping of keys"),
    located("duplicate_keys.yaml", "n_agents", "key given twice"),
    located("billion_laughs.yaml", "", "expands to more than 100,000 values"),
    located("alias_self_reference.yaml", None, "nested too deeply"),
    located("alias_merge_key.yaml", "arena", "keys must be plain words"),
    located("alias_shared_list.yaml", "walls[0].start", "missing required key 'start'"),
    located("undefined_alias.yaml", "", "undefined alias"),
    # A tag on a sequence is dropped, never constructed: os._exit(7) does not run.
    located("python_object_tag.yaml", "n_agents", "valid integer"),
    located("python_name_tag.yaml", "description", "could not determine a constructor"),
    located("custom_tag.yaml", "arena", "could not determine a constructor", "!include"),
    located("binary_tag.yaml", "description", "valid string"),
    located("set_tag.yaml", "n_agents", "keys must be plain words"),
    located("timestamp_value.yaml", "description", "valid string"),
    located("deep_nesting.yaml", "", "nested more than 32 levels deep"),
    located("deep_mappings.yaml", "", "nested more than 32 levels deep"),
    located("two_documents.yaml", "", "another document"),
    located("yaml_directive.yaml", "", "incompatible YAML document"),
    located("non_utf8.yaml", "", "not UTF-8 text", "0xe9"),
    located("utf16.yaml", "", "not UTF-8 text"),
    located("nul_byte.yaml", "", "not valid YAML", "special characters"),
    located("fullwidth_key.yaml", "\uff4e_agents", "unknown key", "did you mean 'n_agents'"),
    located("homoglyph_key.yaml", "n_\u0430gents", "unknown key", "did you mean 'n_agents'"),
    located("unknown_top_key.yaml", "n_agnets", "unknown key", "did you mean 'n_agents'"),
    located("zero_width_color.yaml", "arena.wall.color", "unknown colour name"),
    located("emoji_item_name.yaml", "items[0].name", "should match pattern"),
    located("rtl_override_name.yaml", "items[0].name", "should match pattern"),
    located("key_not_a_word.yaml", "", "keys must be plain words"),
    located("null_key.yaml", "", "keys must be plain words"),
    located("int_key.yaml", "", "keys must be plain words"),
    located("null_section.yaml", "arena", "valid dictionary"),
    located("description_too_long.yaml", "description", "at most 200 characters"),
    # big texts, written at test time
    works("comment_of_1mb.yaml", make=written("comment_of_1mb.yaml", lambda: "# " + "x" * 10**6)),
    works("blank_lines_500k.yaml", make=written("blank_lines_500k.yaml", lambda: "\n" * 500_000)),
    located(
        "string_of_1mb.yaml",
        "description",
        "at most 200 characters",
        make=written("string_of_1mb.yaml", lambda: f'description: "{"x" * 10**6}"\n'),
    ),
    located(
        "key_of_1mb.yaml",
        "",
        "not valid YAML",
        make=written("key_of_1mb.yaml", lambda: "k" * 10**6 + ": 1\n"),
    ),
    located(
        "unknown_keys_5000.yaml",
        "k0",
        "unknown key 'k0'",
        make=written("unknown_keys_5000.yaml", lambda: "".join(f"k{k}: 1\n" for k in range(5000))),
    ),
    located(
        "unknown_keys_49000.yaml",
        "k0",
        "unknown key 'k0'",
        make=written(
            "unknown_keys_49000.yaml", lambda: "".join(f"k{k}: 1\n" for k in range(49_000))
        ),
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
]

NUMBERS = [
    located("float_overflow.yaml", "n_agents", "valid integer", "inf"),
    located("inf_arena.yaml", "arena.size[0]", "finite"),
    located("nan_arena.yaml", "arena.size[1]", "finite"),
    located("huge_arena.yaml", "arena.size[0]", "less than or equal to 10000"),
    located("huge_int_agents.yaml", "n_agents", "less than or equal to 64"),
    located("negative_agents.yaml", "n_agents", "greater than or equal to 1"),
    located("agents_65.yaml", "n_agents", "less than or equal to 64"),
    located("float_agents.yaml", "n_agents", "valid integer"),
    located("float_max_steps.yaml", "episode.max_steps", "valid integer"),
    located("bool_length.yaml", "agent.radius", "valid number", "True"),
    located("bool_count.yaml", "items[0].count", "valid integer", "True"),
    # YAML 1.1 reads 1e300 (no dot) as text
    located("string_number.yaml", "agent.mass", "valid number", "'1e300'"),
    located("quoted_number.yaml", "agent.radius", "valid number", "'10'"),
    located("negative_zero_mass.yaml", "agent.mass", "greater than or equal to 0.001", "-0.0"),
    works("negative_zero_heading.yaml"),
    located("underscore_int.yaml", "n_agents", "less than or equal to 64", "1000"),
    works("hex_octal_sizes.yaml"),  # 0x12C and 0454 are both 300
    located("everything_1e308.yaml", "agent.radius", "less than or equal to 10000"),
    located("rewards_1e308.yaml", "items[0].reward", "less than or equal to 1000000"),
    located("rewards_overflow.yaml", "rules[0].reward", "less than or equal to 1000000"),
    located("nan_reward.yaml", "items[0].reward", "finite"),
    located("inf_step_reward.yaml", "rules[0].reward", "finite"),
    works("huge_obstacle_angle.yaml"),
    located("inf_obstacle_angle.yaml", "obstacles[0].angle", "finite"),
    works("subnormal_rates.yaml"),  # rates, forces and torques only need to be > 0
    works("subnormal_hinge_swing.yaml"),
    located("too_many_rays.yaml", "agent.camera.rays", "less than or equal to 4096"),
    located("camera_fov_zero.yaml", "agent.camera.fov", "greater than 0"),
    works("camera_one_ray_full_circle.yaml"),
    located("tiny_arena.yaml", "agent.radius", "do not fit in the 0.1 x 0.1 arena"),
    located("tiny_world.yaml", "agent.radius", "no room to place every agent"),
]

AT_LEAST = "greater than or equal to"
AT_MOST = "less than or equal to"
MASSES = {"agent": "agent.mass", "head": "agent.head.mass"}
MASSES |= {"hinged_door": "doors[0].mass", "movable_obstacle": "obstacles[0].mass"}

PHYSICS = [
    located("arm_segment_tiny.yaml", "agent.arms[0].segments[0].length", AT_LEAST, "1e-300"),
    *[
        located(f"mass_{who}_{label}.yaml", key, bound, shown)
        for who, key in MASSES.items()
        for label, bound, shown in [
            ("tiny", AT_LEAST, "1e-300"),
            ("subnormal", AT_LEAST, "5e-324"),
            ("huge", AT_MOST, "1e+300"),
        ]
    ],
    located("dt_tiny.yaml", "physics.dt", AT_LEAST),
    located("wall_thickness_tiny.yaml", "arena.wall.thickness", AT_LEAST),
    located("checkers_period_tiny.yaml", "arena.wall.texture.period", AT_LEAST),
    located("noise_period_subnormal.yaml", "arena.wall.texture.period", AT_LEAST, "1e-310"),
    located("gradient_period_subnormal.yaml", "arena.wall.texture.period", AT_LEAST, "5e-324"),
    located("polygon_pentagram.yaml", "obstacles[0]", "convex", "winds 2 times around"),
    located("polygon_triangle_twice.yaml", "obstacles[0]", "vertices 0 and 3 are at the same"),
    located("polygon_sliver.yaml", "obstacles[0]", "0.0001 thick at its thinnest"),
    located("polygon_nan_vertex.yaml", "obstacles[0].vertices[2][1]", "finite"),
    located("polygon_33_vertices.yaml", "obstacles[0].vertices", "at most 32 items"),
    located(
        "grid_rooms_door_too_wide.yaml",
        "layout.generators[0].door_width",
        "do not fit in walls 100 long",
    ),
    # Issue 14's budget of work: big layouts load within seconds, or are refused
    works("random_obstacles_500_large_arena.yaml", time_limit=10.0),
    located("mazes_200.yaml", "layout.generators", "at most 64 items", time_limit=10.0),
    located("items_40_groups_of_10000.yaml", "items[0].count", "work budget", time_limit=10.0),
]

EXTENDS = [
    # A relative path is read from the extending file's folder; this many ../ reach /.
    located("extends_etc_passwd.yaml", "", "must be a mapping", source="/etc/passwd$"),
    located("extends_absolute_passwd.yaml", "", "must be a mapping", source="^/etc/passwd$"),
    located("extends_dev_zero.yaml", "extends", "unknown scenario '/dev/zero'"),
    located("extends_proc_environ.yaml", "", "not valid YAML", source="^/proc/self/environ$"),
    located("extends_proc_mem.yaml", "", "cannot read the file", source="^/proc/self/mem$"),
    located("extends_binary.yaml", "", "not UTF-8 text", source="^/bin/sh$"),
    located("extends_directory.yaml", "extends", "unknown scenario '/tmp'"),
    located("extends_misspelt.yaml", "extends", "did you mean 'fruits_poisons'"),
    located("extends_missing_file.yaml", "extends", "does not exist"),
    located("extends_number.yaml", "extends", "expected the name of a scenario"),
    located("extends_list.yaml", "extends", "expected the name of a scenario"),
    located("extends_empty_string.yaml", "extends", "unknown scenario ''"),
    located("extends_self_by_name.yaml", "extends", "unknown scenario 'extends_self_by_name'"),
    works("extends_null.yaml"),  # `extends: ~` is no extends at all
    located("extends_shipped_then_bad.yaml", "doors[0].key", "no key item group or key object"),
    works("extends_chain_8.yaml", make=extends_chain(8)),
    located(
        "extends_self.yaml",
        "extends",
        "cycle",
        make=extends_self,
    ),
    located(
        "extends_cycle.yaml",
        "extends",
        "cycle",
        source="/cycle_[ab].yaml$",
        make=extends_cycle,
    ),
    located(
        "extends_chain_9.yaml",
        "extends",
        source="/chain_[0-8].yaml$",
        make=extends_chain(9),
    ),
]

LAYOUT = [
    works("overlapping_rooms.yaml"),
    located("door_key_missing.yaml", "doors[0].key", "no key item group or key object 'gold'"),
    located("door_switch_missing.yaml", "doors[0].switch", "no zone named 'plate'"),
    located("hinged_door_with_key.yaml", "doors[0]", "pushed open"),
    located("door_beyond_arena.yaml", "doors[0].end", "outside the 300 x 300 arena"),
    located("zone_outside_arena.yaml", "zones[0].rect", "outside the 300 x 300 arena"),
    located("zone_zero_size.yaml", "zones[0].size[0]", AT_LEAST),
    located("zone_bigger_than_arena.yaml", "zones[0].size", "larger than its area"),
    located("spawn_area_zero_size.yaml", "agent.spawn.area", "x1 > x0"),
    located("spawn_area_inverted.yaml", "agent.spawn.area", "x1 > x0"),
    located("teams_do_not_add_up.yaml", "n_agents", "the teams have 2 agents, not 3"),
    located("teams_too_many.yaml", "n_agents", "the teams have 4 agents, not 2"),
    located("items_negative_count.yaml", "items[0].count", AT_LEAST),
    located("walls_zero_length.yaml", "walls[0]", "at least 0.1 apart"),
    located("corridor_diagonal.yaml", "corridors[0]", "horizontally or vertically"),
    located("obstacle_far_away.yaml", "obstacles[0].position", "outside the 300 x 300 arena"),
    located("opening_wider_than_room.yaml", "rooms[0].openings[0].width", "does not fit"),
    located("door_in_opening_hinged_huge_swing.yaml", "rooms[0].openings[0].door.swing", AT_MOST),
    located("sensors_17.yaml", "agent.sensors", "at most 16 items"),
    located("sensors_same_name.yaml", "agent", "two sensors are called 'camera'"),
    located("maze_cell_tiny.yaml", "layout.generators[0].cell", "work budget"),
    located("maze_loops_too_many.yaml", "layout.generators[0].loops", AT_MOST),
    located("grid_rooms_31_rows.yaml", "layout.generators[0].rows", AT_MOST),
    located("texture_seed_huge.yaml", "arena.wall.texture.seed", AT_MOST),
    located("color_bad_hex.yaml", "arena.wall.color", "not of the form '#rrggbb'"),
    located("color_empty_list.yaml", "arena.wall.color", "three integers"),
    located("respawn_zero.yaml", "items[0].respawn", AT_LEAST),
    located("rule_unknown.yaml", "rules[0]", "'teleport'"),
    located("layout_seed_negative.yaml", "layout.seed", AT_LEAST),
    located("agents_64_arms_cross_walls.yaml", "arena.wall.thickness", "can be crossed"),
    located("continuous_actions_all_parts.yaml", "arena.wall.thickness", "can be crossed"),
    located(
        "items_10001_positions.yaml",
        "items[0].positions",
        "at most 10000 items",
        make=written("items_10001_positions.yaml", lambda: item_positions(10_001)),
    ),
    works("layout_seed_largest.yaml"),
    works("respawn_after_million_steps.yaml"),
    works("item_key_on_no_door.yaml"),
    works("agents_64.yaml"),
    works("physics_heaviest_solver.yaml"),
    works("teleport_zone_everywhere.yaml"),
    works("episode_one_step.yaml"),
    works("end_when_eaten_nothing.yaml"),
    works("maze_10000_cells.yaml", slow=True),
    # the largest legal layouts: seconds of work each
    works("maze_cell_just_under_100.yaml", slow=True),
    works("grid_rooms_30x30_hinged.yaml", slow=True),
    works("camera_max_everything.yaml", steps=2, slow=True),
    works("items_10000_tiny.yaml", slow=True),
    works(
        "items_10000_positions.yaml",
        make=written(
            "items_10000_positions.yaml",
            lambda: "arena: {size: [10000, 10000]}\n" + item_positions(10_000),
        ),
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
    works(
        "sensors_64_agents_16_cameras_4096_rays.yaml",
        make=written("sensors_64_agents_16_cameras_4096_rays.yaml", lambda: sensors(16)),
        steps=2,
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
    bounded(
        "obstacles_10000.yaml",
        make=written("obstacles_10000.yaml", lambda: listing("obstacles", 10_000, circle)),
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
    bounded(
        "hinged_doors_3000.yaml",
        make=written(
            "hinged_doors_3000.yaml",
            lambda: listing("doors", 3000, lambda k: wall(k, kind="kind: hinged, ")),
        ),
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
    bounded(
        "walls_12000.yaml",
        make=written("walls_12000.yaml", lambda: listing("walls", 12_000, two_walls)),
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
    bounded(
        "rooms_3000.yaml",
        make=written("rooms_3000.yaml", lambda: listing("rooms", 3000, room)),
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
    bounded(
        "closed_rooms_10000.yaml",
        make=written("closed_rooms_10000.yaml", lambda: listing("rooms", 10_000, closed_room)),
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
    bounded(
        "zones_10000.yaml",
        make=written("zones_10000.yaml", lambda: listing("zones", 10_000, zone)),
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
    bounded(
        "random_zones_10000.yaml",
        make=written(
            "random_zones_10000.yaml",
            lambda: listing("zones", 10_000, lambda k: "{size: [10, 10], reward: 1}"),
        ),
        slow=True,
        time_limit=HEAVY_TIME_LIMIT,
    ),
]

STRESSED = [
    # legal worlds at the limits of masses, speeds, forces and the solver, run longer
    works("physics_fast_light_agent.yaml", steps=100),
    works("physics_heavy_agent_light_door.yaml", steps=100),
    works("physics_light_agent_heavy_box.yaml", steps=100),
    works("physics_elastic_crowd.yaml", steps=100),
    works("physics_arm_mass_ratios.yaml", steps=100),
]

CASES = [*YAML, *NUMBERS, *PHYSICS, *STRESSED, *EXTENDS, *LAYOUT]
