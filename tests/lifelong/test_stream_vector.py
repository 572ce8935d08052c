"""Stream ids through ``gymnasium.make_vec``: the stream's batched env, one life for all
its worlds; with one world exactly what SyncVectorEnv over one single stream env gives in
each autoreset mode, through task switches and episode ends within a task."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import AutoresetMode

import flatland_ma
from flatland_ma.lifelong import StreamBatchedEnv, load_stream
from flatland_ma.lifelong.gym_vector import StreamVectorEnv

STREAM = "flatland_ma/CrossObjectiveStream-v0"


def _short(tmp_path, announce=False, episode=5):
    """Two tasks of 13 and 9 steps, twice; episodes of ``episode`` steps end within them."""
    path = tmp_path / "short.yaml"
    path.write_text(
        f"announce: {str(announce).lower()}\ncycles: 2\ntasks:\n"
        "  - name: paper\n    scenario: fruits_poisons\n    steps: 13\n"
        f"    overrides: {{episode: {{max_steps: {episode}}}}}\n"
        "  - name: swapped\n    scenario: fruits_poisons\n    steps: 9\n"
        f"    overrides:\n      episode: {{max_steps: {episode}}}\n      items:\n"
        "        - {name: fruits, color: orange, reward: -10, count: 10}\n"
        "        - {name: poisons, color: purple, reward: 10, count: 10}\n"
    )
    return load_stream(path)


@pytest.mark.parametrize("announce", [False, True])
@pytest.mark.parametrize("mode", [AutoresetMode.SAME_STEP, AutoresetMode.NEXT_STEP])
def test_one_world_is_sync_vector_env_over_the_single_stream_env(tmp_path, mode, announce):
    stream = _short(tmp_path, announce)
    vector = gymnasium.make_vec(STREAM, 1, stream=stream, autoreset_mode=mode)
    assert isinstance(vector.unwrapped, StreamVectorEnv)
    reference = gymnasium.make_vec(
        STREAM, 1, vectorization_mode="sync", vector_kwargs={"autoreset_mode": mode}, stream=stream
    )
    assert vector.metadata["autoreset_mode"] == reference.metadata["autoreset_mode"] == mode
    assert vector.observation_space == reference.observation_space
    assert data_equivalence(vector.reset(seed=3), reference.reset(seed=3), exact=True)
    rng = np.random.default_rng(0)
    tasks, switches = set(), 0
    for t in range(50):
        actions = rng.integers(0, 3, 1)
        got, want = vector.step(actions), reference.step(actions)
        assert data_equivalence(got, want, exact=True), t
        tasks.add(int(got[4]["task"][0]))
        final = got[4].get("final_info", {})
        switches += int("task_switch" in got[4] or "task_switch" in final)
    assert tasks == {0, 1} and switches >= 3
    vector.close()
    reference.close()


def test_several_worlds_live_one_life_and_switch_together():
    """Four worlds of cross_objective scaled to 8 agent-steps: two vector steps each."""
    stream = load_stream("cross_objective")
    stream = stream.scaled(8 / stream.task(0).steps)
    vector = gymnasium.make_vec(STREAM, 4, stream=stream)
    assert vector.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    observations, infos = vector.reset(seed=0)
    assert observations.shape == (4, 64, 4) and list(infos["task"]) == [0] * 4
    _, _, _, truncations, infos = vector.step(np.zeros(4, np.int64))
    assert not truncations.any() and "final_obs" not in infos
    observations, _, _, truncations, infos = vector.step(np.zeros(4, np.int64))
    assert truncations.all() and infos["_final_obs"].all()
    assert list(infos["task"]) == [1] * 4  # the next task started in the same step
    assert list(infos["final_info"]["task"]) == [0] * 4 and infos["final_info"]["task_switch"].all()
    # the first task played as in the batched env, whose worlds reset with seed + w
    batched = StreamBatchedEnv(stream, num_worlds=4)
    first, _ = batched.reset(seed=0)
    batched.step(np.zeros(4, np.int64))
    last, *_ = batched.step(np.zeros(4, np.int64))
    np.testing.assert_array_equal(np.stack(infos["final_obs"]), last)
    vector.close()


def test_stream_ids_no_longer_fall_back_to_sync_vector_env_and_render():
    for env_id in flatland_ma.STREAM_GYM_IDS[:2]:
        vector = gymnasium.make_vec(env_id, 2)
        assert isinstance(vector.unwrapped, StreamVectorEnv), env_id
        vector.close()
    vector = gymnasium.make_vec(STREAM, 2, render_mode="rgb_array")
    vector.reset(seed=1)
    frames = vector.render()
    assert len(frames) == 2 and frames[0].ndim == 3
    vector.close()
    with pytest.raises(ValueError, match="DISABLED is not offered"):
        gymnasium.make_vec(STREAM, 2, autoreset_mode=AutoresetMode.DISABLED)


@pytest.mark.parametrize("mode", [AutoresetMode.SAME_STEP, AutoresetMode.NEXT_STEP])
def test_several_worlds_play_the_first_task_as_separate_lives_do_until_the_switch(tmp_path, mode):
    """Three worlds, episodes of 2 steps: until the step at which the shared clock reaches
    the first task's 13 agent-steps, each world is SyncVectorEnv's world over a life of its
    own, through episode ends; at that step the one life switches, the three do not."""
    stream = _short(tmp_path, episode=2)
    vector = gymnasium.make_vec(STREAM, 3, stream=stream, autoreset_mode=mode)
    reference = gymnasium.make_vec(
        STREAM, 3, vectorization_mode="sync", vector_kwargs={"autoreset_mode": mode}, stream=stream
    )
    assert data_equivalence(vector.reset(seed=8), reference.reset(seed=8), exact=True)
    rng = np.random.default_rng(2)
    ended = 0
    for t in range(10):
        actions = rng.integers(0, 3, 3)
        got, want = vector.step(actions), reference.step(actions)
        if _switched(got[4]):
            break
        assert data_equivalence(got, want, exact=True), t
        ended += int(got[3].sum())
    assert _switched(got[4]) and not _switched(want[4]) and ended >= 3
    vector.close()
    reference.close()


def _switched(infos: dict) -> bool:
    return "task_switch" in infos or "task_switch" in infos.get("final_info", {})
