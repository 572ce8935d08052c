"""The work budget: a file that asks for too much in sum is refused before anything is
built, at the entry that adds the most; a reset spends a bounded amount of work; and
the checks that made sparse arenas cost their area are local or constant-time."""

import math

import gymnasium
import numpy as np
import pytest

import flatland_ma
from flatland_ma.build import builder, capacity, scatter
from flatland_ma.build.builder import lay_ground
from flatland_ma.scenario import budget, sizes
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import load_scenario
from flatland_ma.sensors import scent
from flatland_ma.world import placement
from flatland_ma.world.placement import Placer
from tests.scenario_helpers import problems


def _maze(cell):
    return {"generator": "maze", "cell": cell}


OVER = [
    # (overrides, key path reported, what is counted)
    (
        {"arena": {"size": [4000, 4000]}, "layout": {"generators": [_maze(40), _maze(80)]}},
        "layout.generators[0].cell",
        "maze and room-grid cells",
    ),
    (
        {
            "arena": {"size": [6000, 6000]},
            "layout": {"generators": [{"generator": "grid_rooms", "rows": 30, "cols": 30}] * 4},
        },
        "layout.generators[0]",
        "solid shapes",
    ),
    (
        {
            "arena": {"size": [8000, 8000]},
            "layout": {"generators": [{"generator": "random_obstacles", "count": 500}] * 6},
        },
        "layout.generators[0].count",
        "obstacles scattered at random",
    ),
    (
        {
            "arena": {"size": [8000, 8000]},
            "items": [
                {"name": "a", "color": "red", "count": 4000},
                {"name": "b", "color": "blue", "count": 7000},
            ],
        },
        "items[1].count",
        "items",
    ),
    (
        {
            "items": [{"name": "k", "color": "red", "key": True}],
            "doors": [
                {"start": [10 + 5 * i, 0], "end": [10 + 5 * i, 20], "state": "locked", "key": "k"}
                for i in range(budget.MAX_KEYS)
            ],
        },
        "doors[0]",
        "locked doors and keys",
    ),
]


@pytest.mark.parametrize("overrides, where, what", OVER, ids=[w for _, _, w in OVER])
def test_a_file_over_a_total_is_refused_at_its_largest_entry(overrides, where, what):
    (problem,) = problems("fruits_poisons", **overrides)
    assert f": {where}: the scenario asks for " in str(problem)
    assert what in problem.message and "the work budget allows at most" in problem.message


def test_lists_of_groups_are_bounded():
    zones = [{"rect": [10, 10, 20, 20]}] * (budget.MAX_GROUPS + 1)
    (problem,) = problems("fruits_poisons", zones=zones)
    assert problem.path == ("zones",) and f"at most {budget.MAX_GROUPS}" in problem.message


def test_every_shipped_scenario_is_well_within_the_budget():
    for name in flatland_ma.list_scenarios():
        spec = load_scenario(name)
        for total in (budget._cells, budget._shapes, budget._scattered, budget._items):
            counted = total(spec)
            assert counted.total <= counted.limit / 10, (name, counted.what)


def test_a_maze_counts_the_walls_a_spanning_tree_leaves():
    spec = load_scenario("maze_large")
    (gen,) = spec.layout.generators
    cols, rows = budget.maze_size(spec, gen.cell)
    site = lay_ground(spec, np.random.default_rng(0))
    pieces = sum(1 for e in site.world.entities for _ in e.shapes)
    counted = budget._shapes(spec).parts[("layout", "generators", 0, "cell")]
    assert counted == rows * (cols - 1) + cols * (rows - 1) - (rows * cols - 1)
    assert pieces <= budget._shapes(spec).total  # merged pieces are fewer


# --- Overrides: plain data only -------------------------------------------------------


class Sneaky(float):
    def __float__(self):
        raise RuntimeError("not what it seems")


def _loop():
    d: dict = {}
    d["x"] = d
    return d


REFUSED = [
    ({"description": object()}, ("description",), "expected plain data"),
    ({"agent": {"max_speed": Sneaky(10.0)}}, ("agent", "max_speed"), "Sneaky"),
    ({"agent": {"colors": {"red", "blue"}}}, ("agent", "colors"), "set"),
    ({"description": b"bytes"}, ("description",), "bytes"),
    ({"agent": {1: 2}}, ("agent",), "keys must be strings"),
    ({"agent": _loop()}, ("agent",) + ("x",) * 32, "nested more than 32"),
    ({"items": np.zeros(200_000)}, ("items",), "200,000 values"),
    ({"items": [0] * 200_000}, ("items",), "more than 100,000 values"),
    ({"agent": {"max_speed": np.complex128(1)}}, ("agent", "max_speed"), "complex128"),
]


@pytest.mark.parametrize("overrides, path, words", REFUSED, ids=range(len(REFUSED)))
def test_overrides_that_a_file_could_not_hold_are_refused_at_their_key(overrides, path, words):
    with pytest.raises(ScenarioError) as info:
        flatland_ma.parallel_env("fruits_poisons", **overrides)
    (problem,) = info.value.problems
    assert problem.source == "<overrides>" and problem.path[: len(path)] == path
    assert words in problem.message


def test_numpy_numbers_and_tuples_are_plain_data():
    spec = load_scenario(
        "fruits_poisons",
        n_agents=np.int64(2),
        arena={"size": np.array([320.0, 310.0])},
        agent={"max_speed": np.float32(200.0), "colors": ("red", "blue")},
    )
    assert spec.n_agents == 2 and spec.arena.size == (320.0, 310.0)
    assert type(spec.agent.max_speed) is float and spec.agent.max_speed == 200.0


# --- A reset's budget -----------------------------------------------------------------


def test_a_reset_that_draws_too_many_places_is_refused_naming_the_budget(monkeypatch):
    monkeypatch.setattr(placement, "RESET_TRIES", 15)
    spec = load_scenario("fruits_poisons")
    with pytest.raises(ScenarioError) as info:
        builder.build(spec, np.random.default_rng(0), [[] for _ in range(spec.n_agents)])
    (problem,) = info.value.problems
    assert problem.path[:1] == ("items",) and "drew 15 places" in problem.message
    assert "work budget" in problem.message


def test_a_spent_budget_is_not_retried_with_a_new_layout(monkeypatch):
    calls = []
    site = builder._site

    def counting(spec, rng, reset_budget):
        calls.append(1)
        return site(spec, rng, reset_budget)

    monkeypatch.setattr(builder, "_site", counting)
    monkeypatch.setattr(placement, "RESET_SEARCH", 1)
    spec = load_scenario(
        "obstacle_forest",
        layout={"generators": [{"generator": "random_obstacles", "count": 5, "gap": 1}]},
    )
    with pytest.raises(ScenarioError) as info:
        builder.build(spec, np.random.default_rng(0), [[]])
    assert "work budget" in info.value.problems[0].message and len(calls) == 1


# --- Local checks agree with whole-grid ones ------------------------------------------


def _cramped_site(seed):
    """A small arena with random walls and boxes, and its grid, as the scatterer sees it."""
    rng = np.random.default_rng(seed)
    starts = rng.uniform(30, 170, (6, 2))
    steps = rng.choice([-60.0, 0.0, 60.0], (6, 2))
    steps[:, 1] = np.where((steps == 0).all(axis=1), 60.0, steps[:, 1])
    ends = np.clip(starts + steps, 2, 198)
    walls = [{"start": a.tolist(), "end": b.tolist(), "thickness": 4} for a, b in zip(starts, ends)]
    spec = load_scenario(
        "fruits_poisons",
        arena={"size": [200, 200]},
        walls=walls,
        obstacles=[],
        items=[],
        agent={"radius": 6, "spawn": {"area": [20, 20, 70, 70]}},
    )
    return spec, builder.Ground(spec)


@pytest.mark.parametrize("seed", range(6))
def test_the_local_cut_off_check_agrees_with_searching_the_whole_grid(seed):
    """Every obstacle the local check lets through cuts nothing off, checked against a
    search of the whole grid; where the wider window covers the grid, it is exact."""
    spec, ground = _cramped_site(seed)
    world, grid, start = ground.world, ground.grid.copy(), ground.start
    rng = np.random.default_rng(100 + seed)
    reachable = grid.reachable(start)
    seen, exact = {True: 0, False: 0}, 0
    gen = spec.model_validate(
        {
            "layout": {
                "generators": [
                    {"generator": "random_obstacles", "count": 1, "size": [8, 40], "gap": 0}
                ]
            }
        }
    ).layout.generators[0]
    for shape, size, x, y in scatter._draw(gen, rng, 200, 200, 300):
        obstacle = scatter.make_obstacle(scatter._spec(gen, rng, shape, size, x, y), world.space)
        window, mask = grid.window(obstacle.shapes[0], pad=scatter.LOCAL_PADS[0])
        local = scatter._cuts_off(grid, start, reachable, window, mask)
        trial = grid.copy()
        trial.blocked[window] |= mask
        still = trial.reachable(start)
        whole = bool(np.any(reachable & ~trial.blocked & ~still))
        wide, _ = scatter._widen(grid, window, scatter.LOCAL_PADS[-1] - scatter.LOCAL_PADS[0])
        covers = grid.blocked[wide].size == grid.blocked.size
        assert local == whole if covers else local >= whole, (x, y, size)
        seen[whole] += 1
        exact += covers
        if not local and rng.uniform() < 0.3:  # keep some, so that the floor gets crowded
            world.add(obstacle)
            grid, reachable = trial, still
    assert seen[True] > 0 and seen[False] > 0 and exact > 0


def test_free_cells_in_a_rectangle_are_counted_as_the_masks_would():
    spec = load_scenario("seek_avoid_rooms")
    site = lay_ground(spec, np.random.default_rng(0))
    counts = capacity._FreeCells(site.placer)
    rng = np.random.default_rng(1)
    w, h = spec.arena.size
    rects = [None, (0, 0, w, h), (-5, -5, 1e9, 1e9), (50, 50, 50, 50), (120, 30, 40, 90)]
    for _ in range(40):
        x0, x1 = np.sort(rng.uniform(-20, w + 20, 2))
        y0, y1 = np.sort(rng.uniform(-20, h + 20, 2))
        rects.append((float(x0), float(y0), float(x1), float(y1)))
    for rect in rects:
        expected = int(site.placer.mask(rect).sum())
        assert counts.count(rect or (-math.inf, -math.inf, math.inf, math.inf)) == expected


def test_a_grid_window_holds_exactly_the_cells_the_whole_grid_would_block():
    spec, ground = _cramped_site(0)
    world, grid = ground.world, ground.grid
    rng = np.random.default_rng(3)
    gen = spec.model_validate(
        {"layout": {"generators": [{"generator": "random_obstacles", "count": 1}]}}
    ).layout.generators[0]
    for shape, size, x, y in scatter._draw(gen, rng, 200, 200, 50):
        obstacle = scatter.make_obstacle(scatter._spec(gen, rng, shape, size, x, y), world.space)
        window, mask = grid.window(obstacle.shapes[0], pad=2)
        whole = grid.shape_mask(obstacle.shapes[0])
        assert mask.sum() == whole.sum() and (whole[window] == mask).all()


def test_placer_counts_each_place_it_draws_against_the_budget():
    spec = load_scenario("fruits_poisons")
    site = lay_ground(spec, np.random.default_rng(0))
    reset = placement.ResetBudget(tries=3)
    placer = Placer(site.world, site.grid, site.placer.reachable, reset)
    for _ in range(3):
        placer.sample(np.random.default_rng(0), 5.0)
    with pytest.raises(placement.OutOfBudget):
        placer.sample(np.random.default_rng(0), 5.0)
    assert reset.spent


# -- sensors ----------------------------------------------------------------------------


def _maps(n, size=256, **keys):
    return [{"type": "topdown", "size": size, "name": f"map_{i}", **keys} for i in range(n)]


SENSORS_OVER = [
    # (overrides, key path reported, what is counted)
    ({"n_agents": 64, "agent": {"sensors": _maps(16)}}, "agent.sensors[0]", "sensor memory"),
    (
        {
            "n_agents": 64,
            "teams": [
                {"name": "small", "size": 2},
                {"name": "big", "size": 62, "agent": {"sensors": _maps(16, channels=["rgb"])}},
            ],
            "agent": {"sensors": _maps(1, size=32)},
        },
        "teams[1].agent.sensors[0]",
        "sensor memory",
    ),
    (
        {
            "n_agents": 64,
            "agent": {
                "sensors": [{"type": "camera", "rays": 4096}, {"type": "lidar", "rays": 4096}]
            },
        },
        "agent.sensors[0]",
        "rays cast each step",
    ),
    (
        {
            "arena": {"size": [10_000, 10_000]},
            "agent": {
                "sensors": [
                    {"type": "smell", "cell": 1.0, "range": 100.0 + i, "name": f"s{i}"}
                    for i in range(16)
                ]
            },
        },
        "agent.sensors[0]",
        "sensor memory",
    ),
]


@pytest.mark.parametrize(
    "overrides, where, what", SENSORS_OVER, ids=["maps", "team", "rays", "scent"]
)
def test_sensors_over_the_budget_are_refused_where_they_are_written(overrides, where, what):
    with pytest.raises(ScenarioError) as info:
        load_scenario("fruits_poisons", **overrides)
    (problem,) = info.value.problems
    assert str(problem).startswith(f"<overrides>: {where}: the scenario asks for ")
    assert what in problem.message and "the work budget allows at most" in problem.message


def test_large_sensors_within_the_budget_load():
    load_scenario("fruits_poisons", n_agents=64, agent={"sensors": _maps(1)})
    load_scenario("fruits_poisons", n_agents=64, agent={"camera": {"rays": 4096}})
    # One scent field serves every agent that smells the same: counted once.
    smell = {"type": "smell", "cell": 1.0}
    load_scenario(
        "fruits_poisons", n_agents=64, arena={"size": [10_000, 10_000]}, agent={"sensors": [smell]}
    )


@pytest.mark.parametrize("scenario", sorted(flatland_ma.list_scenarios()))
def test_the_sizes_counted_are_the_spaces_built(scenario):
    env = flatland_ma.parallel_env(scenario)
    entries = sum(
        gymnasium.spaces.utils.flatdim(env.observation_space(agent))
        for agent in env.possible_agents
    )
    assert sizes.observation_bytes(env.spec) == 4 * entries
    rays = sum(s.n_rays for agent in env.sensors for s in agent)
    assert sizes.rays_per_step(env.spec) == rays


def test_the_scent_grid_counted_is_the_one_smell_builds():
    assert sizes.SCENT_CELLS == scent.MAX_CELLS


def test_a_batch_is_held_to_the_budget_by_its_worlds_and_processes():
    spec = load_scenario("fruits_poisons")
    most = budget.max_worlds(spec)
    assert 1_000 < most < 100_000  # a thousand worlds of a small scenario fit
    budget.check_batch(spec, most)
    with pytest.raises(ValueError, match=f"worlds=.* at most {most:,} for this scenario"):
        budget.check_batch(spec, most + 1, "worlds")
    fewer = budget.max_worlds(spec, processes=4)
    assert fewer < most
    with pytest.raises(ValueError, match="in 4 processes"):
        budget.check_batch(spec, fewer + 1, processes=4)
    heavy = load_scenario("fruits_poisons", agent={"sensors": _maps(16)})
    assert budget.max_worlds(heavy) < most / 10  # sensor memory counts per world
