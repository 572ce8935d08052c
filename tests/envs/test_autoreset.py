"""The envs of many worlds reset as Gymnasium 1.x defines: each autoreset mode against
Gymnasium's own SyncVectorEnv over the single envs with the same mode, step for step (the
batched and sharded worlds alike), several agents with early finishers against separate
parallel envs, the reset mask, flat observations and rendering."""

import copy

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import AutoresetMode

import flatland_ma
from flatland_ma.envs.flatten import FlatLayout
from flatland_ma.envs.registration import gym_id
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import BatchedParallelEnv

FRUITS = gym_id("fruits_poisons")
GOALS = {
    "items": [
        {"name": "fruits", "color": "orange", "reward": 10, "count": 10},
        {"name": "goals", "color": "lime", "reward": 5, "count": 3, "terminal": True},
    ]
}
"""fruits_poisons_multi with goals that end the episode of the agent taking one."""


def _against_sync(vectors: dict, mode, steps: int, n: int, seed: int = 1, **kwargs):
    """Step ``vectors`` (name -> a make_vec env) and SyncVectorEnv side by side with the
    same actions; in DISABLED reset the finished envs with a mask. Returns how many
    episodes ended (so a test knows its resets were exercised)."""
    reference = gymnasium.make_vec(
        FRUITS, n, vectorization_mode="sync", vector_kwargs={"autoreset_mode": mode}, **kwargs
    )
    ended = 0
    try:
        want = reference.reset(seed=seed)
        for name, env in vectors.items():
            assert env.metadata["autoreset_mode"] == mode == env.unwrapped.autoreset_mode
            assert env.observation_space == reference.observation_space, name
            assert data_equivalence(env.reset(seed=seed), want, exact=True), name
        rng = np.random.default_rng(0)
        for t in range(steps):
            actions = rng.integers(0, 3, n)
            want = reference.step(actions)
            for name, env in vectors.items():
                got = env.step(actions)
                assert data_equivalence(got, want, exact=True), (name, t)
                assert env.observation_space.contains(got[0])
            done = want[2] | want[3]
            ended += int(done.sum())
            if mode == AutoresetMode.DISABLED and done.any():
                seeds = [int(s) for s in rng.integers(0, 1000, n)]
                want = reference.reset(seed=seeds, options={"reset_mask": done.copy()})
                for name, env in vectors.items():
                    got = env.reset(seed=seeds, options={"reset_mask": done.copy()})
                    assert data_equivalence(got, want, exact=True), (name, t)
    finally:
        reference.close()
        for env in vectors.values():
            env.close()
    return ended


@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_each_mode_gives_what_sync_vector_env_gives_batched_and_sharded(mode):
    """Three worlds, episodes of 7 steps, 24 steps: several resets of every world."""
    vectors = {
        "batched": gymnasium.make_vec(FRUITS, 3, max_episode_steps=7, autoreset_mode=mode),
        "sharded": gymnasium.make_vec(
            FRUITS, 3, max_episode_steps=7, autoreset_mode=mode, shards=2
        ),
    }
    assert _against_sync(vectors, mode, 24, 3, max_episode_steps=7) >= 6


def test_same_step_is_make_vecs_default_with_gymnasiums_final_keys():
    env = gymnasium.make_vec(FRUITS, 2, max_episode_steps=3)
    assert env.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    first, _ = env.reset(seed=0)
    for _ in range(2):
        observations, _, _, truncations, infos = env.step(np.zeros(2, np.int64))
        assert not truncations.any() and "final_obs" not in infos
    last = observations
    observations, _, _, truncations, infos = env.step(np.zeros(2, np.int64))
    assert truncations.all() and infos["_final_obs"].all() and infos["_final_info"].all()
    assert infos["final_obs"].dtype == object and infos["final_obs"].shape == (2,)
    assert not np.array_equal(infos["final_obs"][0], last[0])  # the step's own observation
    # the returned observation is the new episode's first one (worlds reset unseeded)
    again = gymnasium.make(FRUITS)
    again.reset(seed=0)
    for _ in range(3):
        final, *_ = again.step(0)
    np.testing.assert_array_equal(infos["final_obs"][0], final)
    np.testing.assert_array_equal(observations[0], again.reset()[0])
    assert set(infos["final_info"]) >= {"score", "_score"}
    env.close()


def test_a_bad_mode_or_reset_mask_is_refused_and_disabled_refuses_to_step_a_finished_world():
    with pytest.raises(ValueError, match="SAME_STEP"):
        BatchedParallelEnv("fruits_poisons", 2, autoreset_mode="sometimes")
    batch = BatchedParallelEnv(
        "fruits_poisons", 2, max_cycles=2, autoreset_mode=AutoresetMode.DISABLED
    )
    batch.reset(seed=0)
    with pytest.raises(TypeError, match="reset_mask"):
        batch.reset(options={"reset_mask": [True, False]})
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        batch.reset(options={"reset_mask": np.ones(3, bool)})
    with pytest.raises(ValueError, match="no world"):
        batch.reset(options={"reset_mask": np.zeros(2, bool)})
    for _ in range(2):
        *_, truncations, _ = batch.step(np.zeros(2, np.int64))
    assert truncations.all()
    with pytest.raises(RuntimeError, match=r"worlds \[0, 1\] are over.*reset_mask"):
        batch.step(np.zeros(2, np.int64))
    assert all(env.num_steps == 2 for env in batch.worlds)
    batch.reset(options={"reset_mask": np.array([True, False])})
    assert batch.worlds[0].num_steps == 0 and batch.worlds[1].num_steps == 2
    with pytest.raises(RuntimeError, match=r"worlds \[1\]"):
        batch.step(np.zeros(2, np.int64))


def _separate_same_step(scenario, n, seed, steps, table, **overrides):
    """What ``n`` separate parallel envs give per step in SAME_STEP mode: stacked
    observations, rewards, terminations, truncations, active flags and final observations
    (slot -> observation)."""
    envs = [flatland_ma.parallel_env(scenario, **overrides) for _ in range(n)]
    names = envs[0].possible_agents
    m = len(names)
    last = [env.reset(seed=seed + w)[0] for w, env in enumerate(envs)]
    zero = np.zeros_like(last[0][names[0]])
    rows = []
    for t in range(steps):
        obs, rew, term, trunc, active, finals = [], [], [], [], [], {}
        for w, env in enumerate(envs):
            live = list(env.agents)
            step = env.step({a: int(table[t, w * m + names.index(a)]) for a in live})
            restart = env.reset()[0] if not env.agents else None
            for j, a in enumerate(names):
                playing = a in live
                seen = step[0][a] if playing else zero
                if playing and (step[2][a] or step[3][a]):
                    finals[w * m + j] = seen
                obs.append(restart[a] if restart is not None else seen)
                rew.append(step[1][a] if playing else 0.0)
                term.append(step[2][a] if playing else False)
                trunc.append(step[3][a] if playing else False)
                active.append(playing or restart is not None)
        rows.append((np.stack(obs), rew, term, trunc, active, finals))
    return rows


@pytest.mark.parametrize("shards", [None, 2])
def test_same_step_with_several_agents_and_early_finishers_matches_separate_envs(shards):
    n, steps = 2, 90
    table = np.random.default_rng(1).integers(0, 3, (steps, n * 4))
    kwargs = dict(max_cycles=40, autoreset_mode="same_step", **GOALS)
    if shards is None:
        batch = BatchedParallelEnv("fruits_poisons_multi", n, **kwargs)
    else:
        batch = ShardedParallelEnv("fruits_poisons_multi", n, shards=shards, **kwargs)
    expected = _separate_same_step(
        "fruits_poisons_multi", n, 11, steps, table, **GOALS, max_cycles=40
    )
    batch.reset(seed=11)
    early = 0
    for t in range(steps):
        observations, rewards, terminations, truncations, infos = batch.step(table[t])
        obs, rew, term, trunc, active, finals = expected[t]
        np.testing.assert_array_equal(observations, obs, err_msg=str(t))
        np.testing.assert_array_equal(rewards, rew)
        np.testing.assert_array_equal(terminations, term)
        np.testing.assert_array_equal(truncations, trunc)
        np.testing.assert_array_equal(infos["active"], active)
        assert set(np.flatnonzero(infos.get("_final_obs", np.zeros(0, bool)))) == set(finals)
        for slot, seen in finals.items():
            np.testing.assert_array_equal(infos["final_obs"][slot], seen)
            assert infos["final_info"]["score"][slot] == infos["final_info"]["score"][slot]
        early += int(terminations.sum())
    batch.close()
    assert early > 0  # some agents took a goal, some before their world's end


@pytest.mark.parametrize("shards", [None, 2])
def test_flat_observations_on_the_batched_and_sharded_envs_keep_the_single_envs_layout(shards):
    sensors = [{"type": "camera"}, {"type": "lidar", "rays": 16}, {"type": "proprioception"}]
    kwargs = dict(max_cycles=6, agent={"sensors": sensors})
    plain = BatchedParallelEnv("fruits_poisons_multi", 2, **kwargs)
    if shards is None:
        flat = BatchedParallelEnv("fruits_poisons_multi", 2, flatten=True, **kwargs)
    else:
        flat = ShardedParallelEnv("fruits_poisons_multi", 2, shards=2, flatten=True, **kwargs)
    single = flatland_ma.parallel_env("fruits_poisons_multi", flatten=True, **kwargs)
    assert flat.single_observation_space == single.observation_space("agent_0")
    assert flat.flat_layout() == single.flat_layout("agent_0")
    layout = FlatLayout(plain.single_observation_space)
    got, want = flat.reset(seed=2)[0], plain.reset(seed=2)[0]
    for t in range(8):  # through a reset (episodes of 6 steps)
        assert got.dtype == np.float32 and got.shape == (8, layout.space.shape[0])
        assert flat.observation_space.contains(got)
        for slot in range(8):
            np.testing.assert_array_equal(
                got[slot], layout.flatten({k: v[slot] for k, v in want.items()})
            )
            assert data_equivalence(
                flat.unflatten(got[slot]), {k: v[slot] for k, v in want.items()}
            )
        actions = np.full(8, t % 3)
        got, want = flat.step(actions)[0], plain.step(actions)[0]
    flat.close()


def test_make_vec_flattens_as_sync_vector_env_over_flat_single_envs():
    vectors = {"flat": gymnasium.make_vec(FRUITS, 2, max_episode_steps=5, flatten=True)}
    assert vectors["flat"].single_observation_space.shape == (256,)
    _against_sync(vectors, AutoresetMode.SAME_STEP, 12, 2, max_episode_steps=5, flatten=True)


def test_vector_envs_render_a_frame_per_world_as_sync_vector_env_does():
    env = gymnasium.make_vec(FRUITS, 2, render_mode="rgb_array")
    sharded = gymnasium.make_vec(FRUITS, 2, render_mode="rgb_array", shards=2)
    reference = gymnasium.make_vec(FRUITS, 2, vectorization_mode="sync", render_mode="rgb_array")
    assert env.metadata["render_modes"] == ["rgb_array"] and env.render_mode == "rgb_array"
    for vector in (env, sharded, reference):
        vector.reset(seed=4)
        vector.step(np.array([0, 1]))
    frames = env.render()
    assert isinstance(frames, tuple) and len(frames) == 2 and frames[0].ndim == 3
    assert data_equivalence(frames, reference.render(), exact=True)
    assert data_equivalence(sharded.render(), frames, exact=True)
    with pytest.raises(ValueError, match="rgb_array"):
        gymnasium.make_vec(FRUITS, 2, render_mode="human")
    for vector in (env, sharded, reference):
        vector.close()


def test_torchrl_wraps_make_vec_unchanged_and_sees_the_final_observations():
    torchrl_gym = pytest.importorskip("torchrl.envs.libs.gym")
    import torch

    vector = gymnasium.make_vec(FRUITS, num_envs=16, max_episode_steps=4)
    seen = []  # what the vector env hands TorchRL at each step
    step = vector.step

    def recorded(actions):
        out = step(actions)
        seen.append(copy.deepcopy(out))  # TorchRL writes into the arrays it is given
        return out

    vector.step = recorded
    env = torchrl_gym.GymWrapper(vector)
    env.set_seed(0)

    def forward(td):  # action 0 (forward) everywhere, one-hot as TorchRL encodes Discrete
        action = torch.zeros(16, 3, dtype=torch.int64)
        action[:, 0] = 1
        td["action"] = action
        return td

    seen.clear()
    rollout = env.rollout(6, policy=forward, break_when_any_done=False)
    assert rollout.batch_size == torch.Size([16, 6]) and len(seen) == 6
    done = rollout["next", "done"].squeeze(-1)
    assert done[:, 3].all() and not done[:, :3].any()
    for t, (observations, rewards, _, truncations, infos) in enumerate(seen):
        following = rollout["next", "observation"][:, t].numpy()
        if t == 3:  # the episodes end: TorchRL's next observation is the final one
            np.testing.assert_array_equal(following, np.stack(infos["final_obs"]))
            assert not np.array_equal(following, observations)
            # every env ended at once, so TorchRL resets them all itself: a new episode
            assert not np.array_equal(rollout["observation"][:, 4].numpy(), following)
        else:
            np.testing.assert_array_equal(following, observations)
        np.testing.assert_array_equal(rollout["next", "reward"][:, t, 0].numpy(), rewards)
        np.testing.assert_array_equal(rollout["next", "truncated"][:, t, 0].numpy(), truncations)
    env.close()


def test_padded_observations_flatten_with_their_role_entry():
    """plate_relay's scout and runner observe differently: pad=True gives one Dict with a
    role entry, and flatten=True lays that Dict out flat, role included."""
    padded = BatchedParallelEnv("plate_relay", 2, max_cycles=5, pad=True)
    flat = BatchedParallelEnv("plate_relay", 2, max_cycles=5, pad=True, flatten=True)
    layout = FlatLayout(padded.single_observation_space)
    assert flat.single_observation_space == layout.space
    assert "role" in [part.name for part in flat.flat_layout()]
    want, got = padded.reset(seed=1)[0], flat.reset(seed=1)[0]
    for _ in range(7):  # through a reset (episodes of 5 steps)
        for slot in range(padded.num_slots):
            one = {key: values[slot] for key, values in want.items()}
            np.testing.assert_array_equal(got[slot], layout.flatten(one))
        actions = [padded.single_action_space.sample() for _ in range(padded.num_slots)]
        want, got = padded.step(actions)[0], flat.step(actions)[0]
