"""Layouts: rooms, openings, corridors and generators give the walls they promise, and
every place an agent may start or find an item can be reached."""

import numpy as np
import pytest

import flatland_ma
from flatland_ma.build import layout
from flatland_ma.build.generators import Maze
from flatland_ma.build.ground import Ground
from flatland_ma.scenario.loader import load_scenario
from flatland_ma.world.entities import Obstacle, Wall


def walls(env):
    return [s for e in env.episode.world.entities if isinstance(e, Wall) for s in e.shapes]


def layout_signature(env):
    shapes = walls(env) + [
        s for e in env.episode.world.entities if isinstance(e, Obstacle) for s in e.shapes
    ]
    return sorted(
        tuple(np.round(np.ravel([tuple(v) for v in s.get_vertices()]), 6)) for s in shapes
    )


def test_a_room_opening_is_a_gap_of_its_width():
    room = {"rect": [100, 100, 200, 200], "openings": [{"side": "east", "offset": 30, "width": 40}]}
    spec = load_scenario("fruits_poisons", obstacles=[], rooms=[room])
    pieces = layout.explicit_layout(spec).walls
    east = sorted((p.start[1], p.end[1]) for p in pieces if p.vertical and p.start[0] == 200)
    # The east side runs from y = 95 to 205 (walls overlap at the corners); the gap is
    # centred 30 above the room's south edge.
    assert east == [(95.0, 110.0), (150.0, 205.0)]


def test_adjacent_rooms_share_one_merged_wall_and_corridors_open_room_walls():
    rooms = [{"rect": [20, 20, 150, 150]}, {"rect": [150, 20, 280, 150]}]
    spec = load_scenario("fruits_poisons", obstacles=[], rooms=rooms)
    shared = [p for p in layout.explicit_layout(spec).walls if p.vertical and p.start[0] == 150]
    assert len(shared) == 1
    spec = load_scenario("corridor_rooms")
    pieces = layout.explicit_layout(spec).walls
    for x in (170, 330):  # the room walls the corridor crosses are open where it runs
        spans = sorted((p.start[1], p.end[1]) for p in pieces if p.vertical and p.start[0] == x)
        assert len(spans) == 2 and spans[0][1] <= 110 and spans[1][0] >= 190


def test_corridor_rooms_connects_its_rooms_and_walls_off_the_rest():
    env = flatland_ma.parallel_env("corridor_rooms")
    env.reset(seed=0)
    grid = env.episode.grid
    west = grid.cells_in((40, 70, 160, 230))
    reach = grid.reachable(west)
    assert reach[grid.cells_in((340, 70, 460, 230)) & ~grid.blocked].all()  # the east room
    assert not reach[grid.cells_in((0, 0, 500, 40)) & ~grid.blocked].any()  # outside the rooms


@pytest.mark.parametrize("loops", [0.0, 0.5])
def test_maze_is_a_spanning_tree_of_its_cells_unless_loops_are_added(loops):
    spec = load_scenario(
        "maze_goal", layout={"generators": [{"generator": "maze", "cell": 50, "loops": loops}]}
    )
    gen = spec.layout.generators[0]
    pieces = Ground(spec)  # the maze's wall pieces, before anything is built
    Maze(gen, spec, ("layout", "generators", 0)).generate(pieces, np.random.default_rng(3))
    # Count the cell-sized wall units (merged pieces span several cells).
    units = sum(
        round((max(abs(p.end[0] - p.start[0]), abs(p.end[1] - p.start[1])) - p.thickness) / 50)
        for p in pieces.walls
    )
    inner_edges = 2 * 8 * 7
    if loops == 0:
        assert units == inner_edges - (64 - 1)
    else:
        assert units < inner_edges - (64 - 1)
    env = flatland_ma.parallel_env("maze_goal", layout=spec.layout.model_dump())
    env.reset(seed=3)
    grid = env.episode.grid
    free = ~grid.blocked
    reach = grid.reachable(free & grid.cells_in((0, 0, 50, 50)))
    assert reach[free].all()  # every free place is connected


def test_grid_rooms_connect_every_room():
    env = flatland_ma.parallel_env("forage_rooms_multi")
    env.reset(seed=5)
    grid = env.episode.grid
    free = ~grid.blocked
    assert grid.reachable(free & grid.cells_in((0, 0, 150, 150)))[free].all()


def test_random_obstacles_do_not_overlap_and_cut_nothing_off():
    env = flatland_ma.parallel_env("obstacle_forest")
    for seed in range(4):
        env.reset(seed=seed)
        world = env.episode.world
        obstacles = [e for e in world.entities if isinstance(e, Obstacle)]
        assert len(obstacles) == 25
        for o in obstacles:
            shape = o.shapes[0]
            others = [h.shape for h in world.space.shape_query(shape)]
            assert all(world.entity_of_shape[s].edible or s is shape for s in others)
        grid = env.episode.grid
        free = ~grid.blocked
        start = np.zeros_like(free)
        start[grid.cell_of(*env.episode.bodies[0].body.position)] = True
        assert grid.reachable(start)[free].all()


def test_layouts_are_new_each_episode_or_fixed_by_a_switch():
    env = flatland_ma.parallel_env("maze_goal")
    env.reset(seed=1)
    a = layout_signature(env)
    env.reset(seed=2)
    b = layout_signature(env)
    env.reset(seed=1)
    assert a != b and layout_signature(env) == a
    fixed = dict(generators=[{"generator": "maze", "cell": 50}], per_episode=False, seed=7)
    env = flatland_ma.parallel_env("maze_goal", layout=fixed)
    env.reset(seed=1)
    a = layout_signature(env)
    env.reset(seed=2)
    assert layout_signature(env) == a
    other = flatland_ma.parallel_env("maze_goal", layout={**fixed, "seed": 8})
    other.reset(seed=1)
    assert layout_signature(other) != a


def _carve_one_by_one(walls, carves):
    """Every carve tried against every wall, as the definition reads."""
    for c in carves:
        out = []
        for w in walls:
            if w.horizontal and c.y0 < w.start[1] < c.y1:
                out += layout._cut(w, 0, c.x0, c.x1)
            elif w.vertical and c.x0 < w.start[0] < c.x1:
                out += layout._cut(w, 1, c.y0, c.y1)
            else:
                out.append(w)
        walls = out
    return walls


@pytest.mark.parametrize("seed", range(5))
def test_carving_by_lines_cuts_what_every_carve_against_every_wall_would(seed):
    rng = np.random.default_rng(seed)
    grid = np.arange(0.0, 200.0, 20.0)  # shared lines, so carves meet several walls

    def wall(k):
        a, b = np.sort(rng.choice(grid, 2, replace=False))
        c = float(rng.choice(grid))
        ends = [((a, c), (b, c)), ((c, a), (c, b)), ((a, a), (b, b))][k % 3]
        start, end = (tuple(map(float, p)) for p in ends)
        return layout.WallPiece(start, end, 4.0, (1, 2, 3), None, ("walls", k))

    walls = [wall(k) for k in range(60)]
    carves = []
    for _ in range(40):
        x0, y0 = rng.uniform(0, 190, 2)
        w, h = rng.uniform(1, 40, 2)
        carves.append(layout.Carve(float(x0), float(y0), float(x0 + w), float(y0 + h)))
    expected = _carve_one_by_one(walls, carves)
    assert layout.carve(walls, carves) == expected and len(expected) > len(walls)
