"""Resets in place: a scenario of a fixed layout keeps its site across episodes (the
world, its walls and fixed obstacles, the grid, the placer) and runs exactly as a world
built from nothing would; one whose layout is drawn each episode builds a new one; and
however many resets, a kept world holds no more than its first episode did."""

import gc

import numpy as np
import pymunk
import pytest

import flatland_ma
from flatland_ma.build.builder import fixed_layout
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.world.physics import shape_counter

SCENARIOS = flatland_ma.list_scenarios()
IN_PLACE = [
    "blind_fetch",
    "coop_carry",
    "corridor_rooms",
    "fetch_object",
    "fruits_poisons",
    "fruits_poisons_multi",
    "push_box",
    "sensor_suite",
    "signal_maps",
    "textured_fruits",
    "tug_of_war",
]
"""The shipped scenarios whose site is kept: a fixed layout without doors."""
EPISODES, CYCLES = 4, 40


def _kept(env: FlatlandParallelEnv) -> bool:
    return env.running.site is not None and env.running.site.mark is not None


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_the_site_is_kept_exactly_for_fixed_layouts_without_doors(scenario):
    env = FlatlandParallelEnv(scenario)
    env.reset(seed=3)
    assert _kept(env) == (scenario in IN_PLACE)
    if _kept(env):
        assert fixed_layout(env.spec) and not env.running.doors


def _state(env: FlatlandParallelEnv) -> list:
    """Every body's pose and velocity, bit for bit."""
    bodies = [e.body for e in env.running.world.entities] + [
        b for e in env.running.world.entities for b in e.aux_bodies
    ]
    return [(*b.position, b.angle, *b.velocity, b.angular_velocity) for b in bodies]


def _same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return np.array_equal(a, b)


@pytest.mark.parametrize("scenario", IN_PLACE)
def test_a_rewound_world_runs_as_one_built_from_nothing(scenario):
    """Episode after episode (random actions, episodes cut short), the env resetting in
    place and one that builds every episode from nothing see, earn and move alike to the
    bit, the world kept the same object all along."""
    kept = FlatlandParallelEnv(scenario, max_cycles=CYCLES)
    fresh = FlatlandParallelEnv(scenario, max_cycles=CYCLES)
    obs_k, _ = kept.reset(seed=11)
    obs_f, _ = fresh.reset(seed=11)
    world = kept.running.world
    spaces = {a: kept.action_space(a) for a in kept.possible_agents}
    for a, space in spaces.items():
        space.seed(5 + kept.possible_agents.index(a))
    for episode in range(EPISODES):
        if episode:
            fresh.episode = None  # builds its next episode from nothing
            obs_k, _ = kept.reset()
            obs_f, _ = fresh.reset()
            assert kept.running.world is world
            assert fresh.running.world is not world
        assert all(_same(obs_k[a], obs_f[a]) for a in obs_k)
        assert _state(kept) == _state(fresh)
        while kept.agents:
            actions = {a: spaces[a].sample() for a in kept.agents}
            step_k = kept.step(actions)
            step_f = fresh.step(actions)
            obs_k, obs_f = step_k[0], step_f[0]
            assert obs_k.keys() == obs_f.keys()
            assert all(_same(obs_k[a], obs_f[a]) for a in obs_k)
            assert step_k[1:4] == step_f[1:4]  # rewards, terminations, truncations
            assert _state(kept) == _state(fresh)
        assert kept.num_steps == fresh.num_steps


def test_a_fixed_layout_keeps_its_static_objects_and_a_drawn_one_does_not():
    env = FlatlandParallelEnv("fruits_poisons_multi")
    env.reset(seed=0)
    first = env.running
    walls = first.world.entities[: first.site.mark.entities]
    bodies = [e.body for e in walls]
    env.reset()
    again = env.running
    assert again.world is first.world and again.world.space is first.world.space
    assert again.grid is first.grid and again.placer is first.placer
    assert all(a is b for a, b in zip(again.world.entities, walls))
    assert [e.body for e in again.world.entities[: len(walls)]] == bodies
    assert again.bodies[0] is not first.bodies[0]  # the agents are placed anew

    drawn = FlatlandParallelEnv("explore_goal")
    drawn.reset(seed=0)
    before = drawn.running
    drawn.reset()
    assert not fixed_layout(drawn.spec)
    assert drawn.running.world is not before.world and drawn.running.grid is not before.grid


def test_a_moved_fixed_entity_makes_the_next_episode_build_its_world_again():
    env = FlatlandParallelEnv("fruits_poisons")
    env.reset(seed=0)
    world = env.running.world
    fixed = next(e for e in world.entities if not e.moving)
    world.move_static(fixed, *fixed.body.position)
    assert world.site_moved
    env.reset()
    assert env.running.world is not world and _kept(env)


def _live_pymunk_objects() -> int:
    gc.collect()
    kinds = (pymunk.Body, pymunk.Shape, pymunk.Constraint)
    # type(), not isinstance(): the process may hold a weak proxy whose object has died
    # (isinstance asks the proxy for its class and raises ReferenceError).
    return sum(issubclass(type(o), kinds) for o in gc.get_objects())


@pytest.mark.parametrize("scenario", ["fruits_poisons_multi", "push_box"])
def test_many_resets_in_place_hold_no_more_than_the_first(scenario):
    """The space's contents, the world's lists, the placer's cache and the shapes' ids
    come back to the same counts at every reset, and no pymunk object outlives its
    episode."""
    env = FlatlandParallelEnv(scenario, max_cycles=30)
    env.action_space(env.possible_agents[0]).seed(0)

    def counts() -> tuple:
        world = env.running.world
        space = world.space
        return (
            len(space.shapes),
            len(space.bodies),
            len(space.constraints),
            len(world.entities),
            len(world.entity_of_shape),
            len(env.running.placer._cells),
            shape_counter(space),
        )

    env.reset(seed=0)
    first = counts()
    baseline = None
    for k in range(40):
        while env.agents:
            env.step({a: env.action_space(a).sample() for a in env.agents})
        env.reset()
        assert counts() == first
        if k == 4:
            baseline = _live_pymunk_objects()
    assert _live_pymunk_objects() <= baseline
