"""Task streams: the shipped files, switching at exactly the stated step in every interface,
the task in the infos (and in the observation when announced), the ecosystem's checkers,
determinism across a switch, background partners, the never-ending drift, and located
faults in stream files."""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence
from pettingzoo.test import api_test, parallel_api_test, state_test

from flatland_ma.lifelong import (
    StreamBatchedEnv,
    StreamGymEnv,
    StreamParallelEnv,
    list_streams,
    load_stream,
    stream_aec_env,
)
from flatland_ma.lifelong.drift import item_rule, reflect
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.world.entities import Item

SWAPPED = (
    "    overrides:\n"
    "      items:\n"
    "        - {name: fruits, color: orange, reward: -10, count: 10}\n"
    "        - {name: poisons, color: purple, reward: 10, count: 10}\n"
)


def two_tasks(tmp_path, first=7, second=5, cycles=1, announce=False, name="s.yaml"):
    path = tmp_path / name
    path.write_text(
        f"announce: {str(announce).lower()}\ncycles: {cycles}\ntasks:\n"
        f"  - {{name: paper, scenario: fruits_poisons, steps: {first}}}\n"
        f"  - name: swapped\n    scenario: fruits_poisons\n    steps: {second}\n" + SWAPPED
    )
    return path


def test_the_shipped_streams_load_with_the_kinds_of_change_the_issue_names():
    assert set(list_streams()) >= {
        "cross_domain",
        "cross_objective",
        "partner_shift",
        "never_ending",
    }
    for name in ("cross_domain", "cross_objective"):
        stream = load_stream(name)
        assert len(stream.task_labels) >= 5
        segments = stream.segments()
        assert [s[0] for s in segments] == list(range(len(stream.task_labels)))
        assert all(a == b for (_, _, a), (_, b, _) in zip(segments, segments[1:]))
    assert load_stream("partner_shift").focal(0) == [0]
    assert load_stream("never_ending").never_ending


def test_the_parallel_env_switches_at_the_stated_step_and_cycles(tmp_path):
    env = StreamParallelEnv(two_tasks(tmp_path, cycles=2))
    observations, infos = env.reset(seed=3)
    assert infos["agent_0"]["task"] == 0
    tasks, switches = [], []
    for step in range(1, 25):
        if not env.agents:
            observations, infos = env.reset()
        _, rewards, terminations, truncations, infos = env.step({"agent_0": step % 3})
        tasks.append(infos["agent_0"]["task"])
        if infos["agent_0"].get("task_switch"):
            assert truncations["agent_0"] and env.agents == []
            switches.append(env.clock)
    assert switches == [7, 12, 19, 24]
    assert tasks == [0] * 7 + [1] * 5 + [0] * 7 + [1] * 5


def test_the_gymnasium_and_aec_envs_switch_at_the_same_step(tmp_path):
    env = StreamGymEnv(two_tasks(tmp_path))
    env.reset(seed=0)
    for step in range(1, 8):
        _, _, terminated, truncated, info = env.step(0)
        assert info["task"] == 0 and truncated == (step == 7) and not terminated
    _, info = env.reset()
    assert info["task"] == 1
    aec = stream_aec_env(two_tasks(tmp_path))
    aec.reset(seed=0)
    steps = 0
    for _ in aec.agent_iter():
        _, _, terminated, truncated, info = aec.last()
        if terminated or truncated:
            assert steps == 7 and info.get("task_switch")
            break
        aec.step(1)
        steps += 1


def test_the_batched_env_switches_every_world_on_the_step_the_count_reaches():
    """Two worlds: each step adds two agent-steps; the 8-step task ends on the 4th step,
    and the next step starts the next task in both worlds."""
    stream = load_stream("cross_objective")
    env = StreamBatchedEnv(stream.scaled(8 / stream.task(0).steps), num_worlds=2)
    observations, infos = env.reset(seed=0)
    assert observations.shape == (2, 64, 4) and list(infos["task"]) == [0, 0]
    for step in range(1, 5):
        _, rewards, terminations, truncations, infos = env.step(np.array([0, 1]))
        assert list(truncations) == [step == 4] * 2 and not terminations.any()
        assert list(infos["task_switch"]) == [step == 4] * 2 and list(infos["task"]) == [0, 0]
    assert env.clock == 8
    _, rewards, terminations, truncations, infos = env.step(np.array([2, 2]))
    assert list(infos["task"]) == [1, 1] and not (rewards.any() or truncations.any())
    assert env.clock == 8  # the step that starts the task uses no action
    env.step(np.array([0, 0]))
    assert env.clock == 10


def test_announcing_adds_the_task_to_the_observation(tmp_path):
    env = StreamParallelEnv(two_tasks(tmp_path, announce=True))
    observations, _ = env.reset(seed=0)
    assert set(observations["agent_0"]) == {"observation", "task"}
    assert list(observations["agent_0"]["task"]) == [1.0, 0.0]
    assert env.observation_space("agent_0").contains(observations["agent_0"])
    for _ in range(7):
        env.step({"agent_0": 0})
    observations, _ = env.reset()
    assert list(observations["agent_0"]["task"]) == [0.0, 1.0]
    silent = StreamParallelEnv(two_tasks(tmp_path, name="t.yaml"))
    assert silent.reset(seed=0)[0]["agent_0"].shape == (64, 4)


def test_the_ecosystem_checkers_pass_on_stream_envs(tmp_path):
    path = two_tasks(tmp_path, first=30, second=30)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        parallel_api_test(StreamParallelEnv(path), num_cycles=80)
        api_test(stream_aec_env(path), num_cycles=80)
        check_env(StreamGymEnv(path), skip_render_check=True)
        parallel_api_test(StreamParallelEnv("partner_shift"), num_cycles=20)
        state_test(stream_aec_env("partner_shift"), StreamParallelEnv("partner_shift"), 20)
        state_test(stream_aec_env(path), StreamParallelEnv(path), num_cycles=80)


def test_every_shipped_stream_has_a_gymnasium_id_that_lives_its_life():
    import gymnasium

    import flatland_ma
    from flatland_ma.envs.registration import stream_gym_id

    assert flatland_ma.STREAM_GYM_IDS == [stream_gym_id(name) for name in list_streams()]
    assert "flatland_ma/CrossObjectiveStream-v0" in flatland_ma.STREAM_GYM_IDS
    for env_id in flatland_ma.STREAM_GYM_IDS:
        env = gymnasium.make(env_id)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            check_env(env.unwrapped, skip_render_check=True)
        made = env.unwrapped
        assert isinstance(made, StreamGymEnv)
        assert stream_gym_id(made.parallel_env.stream.name) == env_id
        env.reset(seed=3)
        _, _, _, _, info = env.step(env.action_space.sample())
        assert info["task"] == 0
        env.close()


def test_the_state_is_the_task_worlds_padded_to_the_longest(tmp_path):
    path = tmp_path / "grow.yaml"
    path.write_text(
        "tasks:\n"
        "  - {name: few, scenario: fruits_poisons, steps: 4}\n"
        "  - name: many\n    scenario: fruits_poisons\n    steps: 4\n"
        "    overrides: {items: [{name: fruits, color: orange, reward: 10, count: 30}]}\n"
    )
    env = StreamParallelEnv(path)
    sizes = [env._env(task).state_space.shape[0] for task in range(2)]
    assert sizes[1] > sizes[0]  # 30 fruits and no poison against 10 and 10
    assert env.state_space.shape == (sizes[1],)
    env.reset(seed=0)
    for task in (0, 0, 0, 0, 1):
        if not env.agents:
            env.reset()
        assert env.task == task
        state = env.state()
        own = env.env.state()
        assert env.state_space.contains(state)
        np.testing.assert_array_equal(state[: own.shape[0]], own)
        assert not state[own.shape[0] :].any()
        labels = env.state_labels
        assert len(labels) == len(state) and labels[: own.shape[0]] == env.env.state_labels
        assert set(labels[own.shape[0] :]) <= {""}
        env.step({agent: env.action_space(agent).sample() for agent in env.agents})
    # The batched env: one row per world, the same padding, across the switch.
    batch = StreamBatchedEnv(path, 2)
    assert batch.single_state_space == env.state_space
    batch.reset(seed=0)
    for task in (0, 0, 0, 1, 1):  # 2 agent-steps a step: the switch at 4, the new task next
        assert batch.task == task
        state, own = batch.state(), batch.env.state()
        assert batch.state_space.contains(state) and state.shape == (2, sizes[1])
        np.testing.assert_array_equal(state[:, : own.shape[1]], own)
        assert not state[:, own.shape[1] :].any()
        batch.step(np.zeros(batch.num_slots, np.int64))


def test_same_seed_and_actions_live_the_same_life_across_a_switch(tmp_path):
    def life(env):
        out, (observation, _) = [], env.reset(seed=11)
        rng = np.random.default_rng(0)
        for _ in range(20):
            observation, reward, terminated, truncated, info = env.step(int(rng.integers(3)))
            out.append((observation.copy(), reward, info["task"]))
            if terminated or truncated:
                observation, _ = env.reset()
                out.append((observation.copy(), 0.0, -1))
        return out

    a, b = life(StreamGymEnv(two_tasks(tmp_path))), life(StreamGymEnv(two_tasks(tmp_path)))
    assert [x[2] for x in a].count(-1) >= 2
    for (oa, ra, ta), (ob, rb, tb) in zip(a, b):
        assert np.array_equal(oa, ob) and ra == rb and ta == tb
    env = StreamGymEnv(two_tasks(tmp_path))
    env.reset(seed=11)
    env.step(0)
    copy = pickle.loads(pickle.dumps(env))
    assert np.array_equal(copy.step(1)[0], env.step(1)[0])


def test_background_partners_play_and_only_the_focal_agent_is_the_learners():
    env = StreamParallelEnv("partner_shift")
    observations, _ = env.reset(seed=0)
    assert env.agents == ["agent_0"] and list(observations) == ["agent_0"]
    start = [env.env.episode.bodies[i].body.position for i in range(4)]
    for _ in range(20):
        env.step({"agent_0": 1})  # the learner only turns
    moved = [(env.env.episode.bodies[i].body.position - start[i]).length for i in range(4)]
    assert moved[0] < 1.0 and min(moved[1:]) > 1.0 and sum(moved) > 60.0  # partners forage
    batched = StreamBatchedEnv("partner_shift", num_worlds=2)
    observations, infos = batched.reset(seed=0)
    assert observations.shape == (2, 64, 4) and batched.num_slots == 2
    batched.step(np.array([0, 0]))
    assert batched.clock == 2


def test_the_never_ending_world_never_ends_and_drifts_as_its_seed_says():
    def run(seed):
        env = StreamParallelEnv("never_ending")
        env.reset(seed=seed)
        items = [i for i in env.env.running.world.of_type(Item)]
        start = [tuple(i.body.position) for i in items]
        for _ in range(1200):  # over twice the scenario's 500 steps
            _, _, terminations, truncations, _ = env.step({"agent_0": 0})
            assert not (terminations["agent_0"] or truncations["agent_0"])
        values = item_rule(env.env).values.copy()
        moved = [np.hypot(*(np.array(i.body.position) - s)) for i, s in zip(items, start)]
        return values, moved

    values, moved = run(4)
    assert np.all(np.abs(values - [10.0, -10.0]) > 0.1) and np.all(np.abs(values) <= 10)
    assert np.median(moved) > 3.0
    again, _ = run(4)
    assert np.array_equal(values, again)
    assert not np.array_equal(values, run(5)[0])


def test_reflection_folds_a_walk_back_between_its_bounds():
    assert np.allclose(
        reflect(np.array([1.5, -1.25, 0.25, 3.5]), -1.0, 1.0), [0.5, -0.75, 0.25, -0.5]
    )


@pytest.mark.parametrize(
    "body, where, words",
    [
        ("bogus: 1\ntasks: [{name: a, scenario: fruits_poisons, steps: 5}]\n", "bogus", ""),
        (
            "tasks:\n  - {name: a, scenario: fruits_poisons, steps: 10}\n"
            "  - name: b\n    scenario: fruits_poisons\n    steps: 10\n"
            "    overrides: {items: [{name: x, color: nocolour}]}\n",
            "tasks[1].overrides",
            "nocolour",
        ),
        (
            "tasks:\n  - {name: a, scenario: fruits_poisons, steps: 10}\n"
            "  - name: b\n    scenario: fruits_poisons\n    steps: 10\n"
            "    overrides: {agent: {camera: {rays: 32}}}\n",
            "tasks[1]",
            "one policy lives the whole life",
        ),
        (
            "tasks:\n  - {name: a, scenario: fruit_poisons, steps: 10}\n",
            "tasks[0].scenario",
            "did you mean",
        ),
        ("tasks:\n  - {name: a, scenario: fruits_poisons, steps: 0}\n", "tasks[0].steps", ""),
        (
            "tasks:\n  - {name: a, scenario: fruits_poisons_multi, steps: 5, focal: [agent_0]}\n",
            "tasks[0]",
            "go together",
        ),
        (
            "tasks:\n  - {name: a, scenario: fruits_poisons, steps: 5}\n"
            "  - {name: a, scenario: fruits_poisons, steps: 5}\n",
            "tasks[1].name",
            "names tasks[0]",
        ),
    ],
)
def test_faults_in_stream_files_are_located(tmp_path, body, where, words):
    path = tmp_path / "bad.yaml"
    path.write_text(body)
    with pytest.raises(ScenarioError) as caught:
        load_stream(path)
    problem = caught.value.problems[0]
    assert problem.source == str(path) and problem.line is not None
    assert str(problem).startswith(f"{path}:{problem.line}: {where}")
    assert words in str(problem)


def test_a_copy_of_a_life_with_partners_goes_on_as_the_original():
    env = StreamParallelEnv("partner_shift")
    env.reset(seed=0)
    env.step({"agent_0": 0})
    copy = pickle.loads(pickle.dumps(env))
    for action in (1, 0, 2):
        mine, theirs = env.step({"agent_0": action}), copy.step({"agent_0": action})
        assert np.array_equal(mine[0]["agent_0"], theirs[0]["agent_0"])
        assert mine[1] == theirs[1]


def test_the_batched_never_ending_world_never_ends():
    env = StreamBatchedEnv("never_ending", num_worlds=2)
    env.reset(seed=0)
    start = item_rule(env.env.worlds[0]).values.copy()
    for _ in range(600):
        _, _, terminations, truncations, infos = env.step(np.zeros(2, np.int64))
        assert not (terminations.any() or truncations.any()) and infos["active"].all()
    assert not np.array_equal(item_rule(env.env.worlds[0]).values, start)


def test_the_batched_env_announces_the_task_when_the_stream_says_so(tmp_path):
    env = StreamBatchedEnv(two_tasks(tmp_path, first=4, announce=True), num_worlds=2)
    observations, _ = env.reset(seed=0)
    assert env.single_observation_space.contains({k: v[0] for k, v in observations.items()})
    assert observations["task"].tolist() == [[1.0, 0.0]] * 2
    for _ in range(2):
        env.step(np.array([0, 0]))
    observations, *_ = env.step(np.array([0, 0]))  # the step that starts the next task
    assert observations["task"].tolist() == [[0.0, 1.0]] * 2
    assert observations["observation"].shape == (2, 64, 4)


def with_random_partners(tmp_path):
    path = tmp_path / "partners.yaml"
    path.write_text(
        "tasks:\n"
        "  - {name: a, scenario: fruits_poisons_multi, focal: [agent_0], background: random,"
        " steps: 9}\n"
        "  - {name: b, scenario: fruits_poisons_multi, focal: [agent_0], background: idle,"
        " steps: 9}\n"
    )
    return path


def _life_after(env, step, bad_at, bad):
    """Observations and rewards of a life of 14 steps of action 1, with ``bad`` tried (and
    refused) before step ``bad_at``."""
    out = [env.reset(seed=2)[0]]
    for t in range(14):
        if t == bad_at:
            with pytest.raises(ValueError) as caught:
                step(env, bad)
            out.append(str(caught.value))
        out.append(step(env, None))
    return out


def _same_lives(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        if isinstance(x, str) or isinstance(y, str):
            continue
        assert data_equivalence(x, y, exact=True)


def _parallel_step(env, bad):
    if not env.agents:
        return env.reset()[0]
    return env.step({"agent_0": 1 if bad is None else bad})[:2]


def _gym_step(env, bad):
    result = env.step(1 if bad is None else bad)
    if result[2] or result[3]:
        return env.reset()[0]
    return result[:2]


def _batched_step(env, bad):
    actions = np.ones(env.num_slots, np.int64).astype(object)
    if bad is not None:
        actions[1] = bad
    return env.step(actions)[:2]


@pytest.mark.parametrize("bad", [3, -1, float("nan"), np.array([0, 1]), "forward"], ids=repr)
@pytest.mark.parametrize("kind", ["parallel", "gym", "batched"])
def test_a_bad_action_names_agent_value_and_space_and_changes_nothing(tmp_path, kind, bad):
    """Nothing moves, the clock stands, and the random partners draw nothing: the life
    goes on as if the bad action had never been offered (also across the switch)."""
    path = with_random_partners(tmp_path)
    make, step = {
        "parallel": (lambda: StreamParallelEnv(path), _parallel_step),
        "gym": (lambda: StreamGymEnv(path), _gym_step),
        "batched": (lambda: StreamBatchedEnv(path, 2), _batched_step),
    }[kind]
    tried = _life_after(make(), step, 4, bad)
    clean = _life_after(make(), step, -1, bad)
    message = next(x for x in tried if isinstance(x, str))
    assert repr(bad) in message and "Discrete(3)" in message
    assert ("slot 1" if kind == "batched" else "agent_0") in message
    _same_lives([x for x in tried if not isinstance(x, str)], clean)


def test_actions_for_agents_the_learner_does_not_drive_are_refused(tmp_path):
    env = StreamParallelEnv(with_random_partners(tmp_path))
    env.reset(seed=0)
    with pytest.raises(ValueError, match="agent_1.*not a live agent"):
        env.step({"agent_0": 0, "agent_1": 0})
    with pytest.raises(ValueError, match="no action given for live agent 'agent_0'"):
        env.step({})


def test_roles_that_observe_differently_share_one_padded_space_when_the_learner_pads(tmp_path):
    """plate_relay's scout and runner see with cameras of 64 and 32 rays: one network
    drives both only through the padded space (baselines.ppo's), which must then agree
    from task to task."""
    path = tmp_path / "roles.yaml"
    task = "  - {{name: {0}, scenario: plate_relay, steps: 5{1}}}\n"
    latched = ", overrides: {doors: [{start: [250, 100], end: [250, 150], switch: plate, "
    latched += "latch: true}]}"
    path.write_text("tasks:\n" + task.format("latched", latched) + task.format("task", ""))
    with pytest.raises(ScenarioError, match=r"tasks\[0\]: the learner's agents have different"):
        load_stream(path)
    assert load_stream(path, padded=True).task_labels == ["latched", "task"]
    wider = ", overrides: {teams: [{name: scout, agent: {radius: 6, camera: {rays: 48}}}, "
    wider += "{name: runner, agent: {radius: 12, camera: {rays: 32}}}]}"
    path.write_text("tasks:\n" + task.format("task", "") + task.format("wider", wider))
    with pytest.raises(ScenarioError, match=r"tasks\[1\]: the learner observes Dict"):
        load_stream(path, padded=True)
