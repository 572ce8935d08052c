"""The step's shortcuts give what the long way gives, number for number:

- a task skips its rules in a step where nothing happened (``Task._quiet``): the same
  trajectories as a task that runs every rule every step, on every scenario;
- the batched env writes a world's counters only when its task's ``revision`` moved:
  every slot's counters still equal its agent's ``info`` every step, items taken and all;
- the batched env drives every body from the batch's array while every slot acts, for
  continuous actions too: what separate envs play;
- worlds of a fixed layout share the ray kernel's grid and eyes; generated layouts keep
  their own;
- a world steps its space through Chipmunk directly when pymunk has nothing queued around
  the step: the same trajectories as ``Space.step``, and what callbacks queue during the
  step is done after it as pymunk does.
"""

import numpy as np
import pymunk
import pytest
from gymnasium.utils.env_checker import data_equivalence

import flatland_ma
from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.world import physics

SCENARIOS = flatland_ma.list_scenarios()


def _long_way(env) -> None:
    env.running.task._quiet = False


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_a_quiet_step_gives_what_every_rule_gives(scenario):
    short = flatland_ma.parallel_env(scenario, max_cycles=40)
    long = flatland_ma.parallel_env(scenario, max_cycles=40)
    rng = np.random.default_rng(3)
    quiet = 0
    for episode in range(2):
        a, _ = short.reset(seed=11 + episode)
        b, _ = long.reset(seed=11 + episode)
        _long_way(long)
        assert data_equivalence(a, b, exact=True)
        while short.agents:
            quiet += short.running.task._quiet
            actions = {}
            for agent in short.agents:
                space = short.action_space(agent)
                space.seed(int(rng.integers(1 << 30)))
                actions[agent] = space.sample()
            one, two = short.step(actions), long.step(actions)
            assert data_equivalence(one, two, exact=True)
        assert not long.agents
    if scenario == "fruits_poisons":
        assert quiet > 0  # the shortcut was there to take


def test_counters_follow_the_agents_info_as_items_are_taken():
    batch = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, max_cycles=150)
    batch.reset(seed=5)
    batch.single_action_space.seed(5)
    m = batch.agents_per_world
    taken = 0
    for _ in range(400):
        actions = np.array([batch.single_action_space.sample() for _ in range(batch.num_slots)])
        _, _, _, _, infos = batch.step(actions)
        for w, env in enumerate(batch.worlds):
            task = env.running.task
            for i in range(m):
                if infos["active"][w * m + i] and task.steps:
                    own = task.info(i)
                    for key, value in own.items():
                        assert infos[key][w * m + i] == value, (key, w, i)
        taken = max(taken, int(infos["fruits"].max()))
    assert taken > 0  # counters did move


def test_continuous_actions_batched_play_what_separate_envs_play():
    options = {"agent": {"actions": "continuous"}, "max_cycles": 15}
    batch = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, **options)
    envs = [flatland_ma.parallel_env("fruits_poisons_multi", **options) for _ in range(2)]
    m = batch.agents_per_world
    batch.reset(seed=8)
    for w, env in enumerate(envs):
        env.reset(seed=8 + w)
    rng = np.random.default_rng(8)
    for _ in range(14):  # within one episode: every slot acts every step
        actions = rng.uniform(-1, 1, (batch.num_slots, 3)).astype(np.float32)
        observations, rewards, *_ = batch.step(actions)
        for w, env in enumerate(envs):
            obs, rew, *_ = env.step({a: actions[w * m + j] for j, a in enumerate(env.agents)})
            for j, agent in enumerate(env.possible_agents):
                assert data_equivalence(observations[w * m + j], obs[agent], exact=True)
                assert rewards[w * m + j] == rew[agent]


def test_rewards_and_ends_written_at_once_are_what_separate_envs_give():
    # Every slot acts from one array: the batch writes every world's rewards and
    # terminations in one go after its loop. Through items taken and resets, they are
    # the separate envs' slot for slot.
    batch = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, max_cycles=60)
    envs = [flatland_ma.parallel_env("fruits_poisons_multi", max_cycles=60) for _ in range(2)]
    m = batch.agents_per_world
    batch.reset(seed=3)
    for w, env in enumerate(envs):
        env.reset(seed=3 + w)
    batch.single_action_space.seed(3)
    rewarded = truncated = 0
    for _ in range(200):
        actions = np.array([batch.single_action_space.sample() for _ in range(batch.num_slots)])
        _, rewards, terminations, truncations, _ = batch.step(actions)
        want = []
        for w, env in enumerate(envs):
            if not env.agents:  # the batch resets this world in this step
                env.reset()
                want += [(0.0, False, False)] * m
                continue
            _, rew, term, trunc, _ = env.step(
                {a: actions[w * m + j] for j, a in enumerate(env.possible_agents)}
            )
            want += [(rew[a], term[a], trunc[a]) for a in env.possible_agents]
        np.testing.assert_array_equal(rewards, [r for r, _, _ in want])
        np.testing.assert_array_equal(terminations, [t for _, t, _ in want])
        np.testing.assert_array_equal(truncations, [t for _, _, t in want])
        rewarded += int(np.count_nonzero(rewards))
        truncated += int(truncations.any())
    assert rewarded > 0 and truncated >= 3  # items were taken, episodes ran out


def _grids(batch):
    return {batch.core.kernel.worlds[w][2].cell_full.ctypes.data for w in range(batch.num_worlds)}


def test_fixed_layouts_share_the_kernels_grid_and_generated_ones_do_not():
    fixed = BatchedParallelEnv("fruits_poisons", num_worlds=3)
    fixed.reset(seed=0)
    assert len(_grids(fixed)) == 1
    drawn = BatchedParallelEnv("maze_goal", num_worlds=3)
    drawn.reset(seed=0)
    assert len(_grids(drawn)) == 3
    for batch in (fixed, drawn):  # the eyes are alike in every world of both
        assert (
            len(
                {
                    batch.core.kernel.worlds[w][4].ray_dir.ctypes.data
                    for w in range(batch.num_worlds)
                }
            )
            == 1
        )


def test_the_grid_cache_gives_what_binning_gives_and_stays_bounded():
    from flatland_ma.sensors import scene

    env = flatland_ma.parallel_env("fruits_poisons")
    env.reset(seed=0)
    shapes = env.running.sensors.geometry.shapes
    fixed_seg = np.ones(len(shapes.seg_local), bool)
    fixed_seg[shapes.loose_seg] = False
    fixed_circ = np.ones(len(shapes.circ_local), bool)
    fixed_circ[shapes.loose_circ] = False
    args = (shapes.seg_local, fixed_seg, shapes.circ_local, fixed_circ)
    assert scene.fixed_grid(*args) is env.running.sensors.geometry.grid
    assert data_equivalence(tuple(scene.fixed_grid(*args)), tuple(scene.bin_fixed_shapes(*args)))
    maze = flatland_ma.parallel_env("maze_goal")
    for seed in range(scene.KEPT + 6):
        maze.reset(seed=seed)
    assert len(scene._KEPT) == scene.KEPT


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_the_direct_space_step_gives_what_pymunks_step_gives(scenario, monkeypatch):
    assert physics.TIER is physics.Tier.COMPILED  # the pinned pymunk: the shortcut is taken
    fast = flatland_ma.parallel_env(scenario, max_cycles=30)
    slow = flatland_ma.parallel_env(scenario, max_cycles=30)
    a, _ = fast.reset(seed=2)
    monkeypatch.setattr(physics, "TIER", physics.Tier.BATCH)  # a world built now: Space.step
    b, _ = slow.reset(seed=2)
    assert fast.episode.world._step is not slow.episode.world._step
    rng = np.random.default_rng(2)
    while fast.agents:
        actions = {}
        for agent in fast.agents:
            space = fast.action_space(agent)
            space.seed(int(rng.integers(1 << 30)))
            actions[agent] = space.sample()
        one = fast.step(actions)
        two = slow.step(actions)
        assert data_equivalence(one, two, exact=True)
        np.testing.assert_array_equal(fast.state(), slow.state())


def _colliding_pair():
    space = pymunk.Space()
    shapes = []
    for x in (0.0, 1.5):
        body = pymunk.Body(1.0, 1.0)
        body.position = (x, 0.0)
        shape = pymunk.Circle(body, 1.0)
        shape.collision_type = 1
        space.add(body, shape)
        shapes.append(shape)
    ran = []

    def begin(arbiter, space, data):
        space.remove(shapes[1])  # queued: the space is locked during the step
        space.add_post_step_callback(lambda s, key: ran.append(len(s.shapes)), "after")

    space.on_collision(1, 1, begin=begin)
    return space, ran


def test_what_callbacks_queue_during_a_direct_step_is_done_after_it():
    fast, fast_ran = _colliding_pair()
    slow, slow_ran = _colliding_pair()
    physics.step_directly(fast, 1e-3)
    slow.step(1e-3)
    assert slow_ran == [1] and len(slow.shapes) == 1  # the pair met in the step
    assert fast_ran == slow_ran and len(fast.shapes) == len(slow.shapes)
    assert not (fast._add_later or fast._remove_later or fast._post_step_callbacks)
    assert [b.position for b in fast.bodies] == [b.position for b in slow.bodies]
