"""Issue 27, the single envs: flat observations (``flatten=True``), agents named by role,
actions for finished agents ignored, render modes that say what this install can do, and
one ``Discrete`` action for channel scenarios."""

import ast
import pickle
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import api_test, parallel_api_test, seed_test

import flatland_ma
from flatland_ma.envs.flatten import WHOLE, FlatLayout, FlattenObservations
from flatland_ma.envs.render_modes import RENDER_MODES, available_render_modes
from flatland_ma.evaluation.runner import focal_agents
from flatland_ma.integrations.discrete import DiscreteActions, discrete_aec_env

FRUITS = "flatland_ma/FruitsPoisons-v0"
EARLY_EXIT = dict(  # terminal zones end agents one by one; the others play on
    zones=[{"rect": [0, 0, 100, 300], "terminal": True, "reward": 1.0}],
    n_agents=3,
    episode={"max_steps": 300},
)
FLAT_CASES = {
    "box": ("fruits_poisons_multi", {}),
    "dict": ("sensor_suite", {}),
    "heterogeneous": ("plate_relay", {}),
    "channel": ("signal_rooms", {}),
    "early_exit": ("fruits_poisons_multi", EARLY_EXIT),
}


def ignore_known_warnings(env) -> None:
    """The AEC checker's warnings that a scenario's kind implies (see tests/envs/test_api.py)."""
    spec = env.unwrapped.spec
    if spec.channel is not None:  # MultiDiscrete: a move and words
        warnings.filterwarnings("ignore", "Action space for each agent probably")
    if spec.heterogeneous:
        warnings.filterwarnings("ignore", "Agents have different observation space sizes")
        warnings.filterwarnings("ignore", "Agents have different action space sizes")
        warnings.filterwarnings("ignore", "Observations are different shapes")


# -- flat observations ------------------------------------------------------------------


@pytest.mark.parametrize("case", sorted(FLAT_CASES))
def test_flat_observations_pass_pettingzoos_checkers(case):
    scenario, kwargs = FLAT_CASES[case]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(
            flatland_ma.parallel_env(scenario, flatten=True, **kwargs), num_cycles=150
        )
        aec = flatland_ma.env(scenario, flatten=True, **kwargs)
        ignore_known_warnings(aec)
        api_test(aec, num_cycles=100)
    seed_test(lambda: flatland_ma.env(scenario, flatten=True, **kwargs), num_cycles=50)


@pytest.mark.parametrize("case", sorted(FLAT_CASES))
def test_a_flat_observation_is_the_unflattened_one_laid_out_and_comes_back(case):
    scenario, kwargs = FLAT_CASES[case]
    flat = flatland_ma.parallel_env(scenario, flatten=True, **kwargs)
    plain = flatland_ma.parallel_env(scenario, **kwargs)
    for agent in flat.possible_agents:
        space = flat.observation_space(agent)
        assert space is flat.observation_space(agent)  # the same object every call
        assert isinstance(space, gymnasium.spaces.Box) and space.dtype == np.float32
        parts = flat.flat_layout(agent)
        assert parts[0].start == 0 and parts[-1].stop == space.shape[0]
        assert all(a.stop == b.start for a, b in zip(parts, parts[1:]))
        original = plain.observation_space(agent)
        if isinstance(original, gymnasium.spaces.Dict):
            assert [p.name for p in parts] == list(original.spaces)
            assert all(p.shape == original[p.name].shape for p in parts)
        else:
            assert [(p.name, p.shape) for p in parts] == [(WHOLE, original.shape)]
    observations, _ = flat.reset(seed=3)
    originals, _ = plain.reset(seed=3)
    for k, agent in enumerate(plain.possible_agents):
        plain.action_space(agent).seed(k)
    for _ in range(40):
        for agent, vector in observations.items():
            assert vector.dtype == np.float32 and flat.observation_space(agent).contains(vector)
            back = flat.unflatten(agent, vector)
            expected = originals[agent]
            if isinstance(expected, dict):
                assert back.keys() == expected.keys()
                for key in expected:
                    np.testing.assert_array_equal(back[key], expected[key])
                    assert back[key].dtype == expected[key].dtype
            else:
                np.testing.assert_array_equal(back, expected)
            part = flat.flat_layout(agent)[0]
            first = expected[part.name] if isinstance(expected, dict) else expected
            np.testing.assert_array_equal(vector[part.start : part.stop], first.reshape(-1))
        if not flat.agents:
            break
        actions = {a: plain.action_space(a).sample() for a in flat.agents}
        observations, *_ = flat.step(actions)
        originals, *_ = plain.step(actions)


def test_flatten_needs_a_flag_and_flat_methods_need_it():
    with pytest.raises(TypeError, match="flatten must be True or False"):
        flatland_ma.parallel_env("fruits_poisons", flatten="yes")
    plain = flatland_ma.parallel_env("fruits_poisons")
    with pytest.raises(ValueError, match="flatten=True"):
        plain.flat_layout("agent_0")


def test_uint8_and_float64_bounds_keep_their_values_inside_float32():
    layout = FlatLayout(
        gymnasium.spaces.Dict(
            {
                "pixels": gymnasium.spaces.Box(0, 255, (2, 2), np.uint8),
                "wide": gymnasium.spaces.Box(-0.1, 1 / 3, (2,), np.float64),
            }
        )
    )
    assert layout.space.dtype == np.float32 and layout.space.shape == (6,)
    assert layout.space.low[4] <= -0.1 and layout.space.high[4] >= 1 / 3
    observation = {
        "pixels": np.array([[0, 7], [200, 255]], np.uint8),
        "wide": np.array([-0.1, 1 / 3]),
    }
    vector = layout.flatten(observation)
    assert layout.space.contains(vector)
    back = layout.unflatten(vector)
    assert back["pixels"].dtype == np.uint8
    np.testing.assert_array_equal(back["pixels"], observation["pixels"])
    with pytest.raises(ValueError, match="shape"):
        layout.unflatten(vector[:-1])


def test_the_wrapper_and_the_option_give_the_same_vectors():
    option = flatland_ma.parallel_env("sensor_suite", flatten=True)
    wrapper = FlattenObservations(flatland_ma.parallel_env("sensor_suite"))
    assert option.observation_space("agent_0") == wrapper.observation_space("agent_0")
    assert option.flat_layout("agent_0") == wrapper.flat_layout("agent_0")
    a, _ = option.reset(seed=1)
    b, _ = wrapper.reset(seed=1)
    np.testing.assert_array_equal(a["agent_0"], b["agent_0"])


@pytest.mark.parametrize("env_id", [FRUITS, "flatland_ma/SensorSuite-v0"])
def test_gymnasium_make_flatten_passes_check_env(env_id):
    env = gymnasium.make(env_id, flatten=True)
    space = env.observation_space
    assert isinstance(space, gymnasium.spaces.Box) and space.shape is not None
    assert len(space.shape) == 1 and space.dtype == np.float32
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
    observation, _ = env.reset(seed=0)
    for _ in range(5):
        observation, *_ = env.step(0)
        assert space.contains(observation)
    back = env.unwrapped.unflatten(observation)
    plain = gymnasium.make(env_id).observation_space
    assert plain.contains(back)
    size = sum(np.size(v) for v in back.values()) if isinstance(back, dict) else np.size(back)
    assert size == space.shape[0]


def test_a_flat_env_stays_flat_through_pickling():
    env = flatland_ma.parallel_env("sensor_suite", flatten=True)
    env.reset(seed=2)
    for _ in range(3):
        env.step({"agent_0": 1})
    copy = pickle.loads(pickle.dumps(env))
    assert copy.flatten and copy.observation_space("agent_0") == env.observation_space("agent_0")
    mine, *_ = env.step({"agent_0": 0})
    theirs, *_ = copy.step({"agent_0": 0})
    np.testing.assert_array_equal(mine["agent_0"], theirs["agent_0"])
    assert theirs["agent_0"].ndim == 1


# -- names by role ----------------------------------------------------------------------


def test_agents_of_teams_are_named_by_team_and_others_keep_agent_i():
    relay = flatland_ma.parallel_env("plate_relay")
    assert relay.possible_agents == ["scout_0", "runner_0"]
    assert relay.observation_space("scout_0").shape == (64, 4)
    assert relay.observation_space("runner_0").shape == (32, 4)
    assert relay.state_labels[0] == "scout_0.x" and "runner_0.vx" in relay.state_labels
    tug = flatland_ma.parallel_env("tug_of_war")
    teams = [t.name for t in tug.spec.teams]
    assert tug.possible_agents == [f"{t}_{k}" for t in teams for k in range(2)]
    assert flatland_ma.parallel_env("fruits_poisons_multi").possible_agents == [
        f"agent_{i}" for i in range(4)
    ]
    signal = flatland_ma.env("signal_rooms")
    assert signal.possible_agents == ["guide_0", "seeker_0"]
    assert signal.unwrapped.state_labels[-2:] == ("guide_0.say_0", "seeker_0.say_0")


def test_suites_find_agents_by_team_and_by_role_name():
    env = flatland_ma.parallel_env("plate_relay")
    assert focal_agents(env, ["scout"]) == ["scout_0"]
    assert focal_agents(env, ["runner_0"]) == ["runner_0"]
    with pytest.raises(ValueError, match="agent_0"):
        focal_agents(env, ["agent_0"])


def test_suite_and_stream_files_name_focal_agents_by_role():
    from flatland_ma.policies.references import focal_indices
    from flatland_ma.scenario.errors import SpecError

    relay = flatland_ma.load_scenario("plate_relay")
    assert focal_indices(relay, ["runner_0"], "plate_relay") == [1]
    assert focal_indices(relay, ["scout"], "plate_relay") == [0]
    with pytest.raises(SpecError, match="'agent_1' is no agent or team.*scout_0, runner_0"):
        focal_indices(relay, ["agent_1"], "plate_relay")


def test_names_within_teams_are_numbered_per_team():
    env = flatland_ma.parallel_env(
        "fruits_poisons_multi",
        teams=[{"name": "red", "size": 3}, {"name": "red_1", "size": 1}],
    )
    assert env.possible_agents == ["red_0", "red_1", "red_2", "red_1_0"]
    assert len(set(env.possible_agents)) == 4
    observations, _ = env.reset(seed=0)
    assert list(observations) == env.possible_agents


def test_the_pettingzoo_name_carries_the_new_version():
    assert flatland_ma.parallel_env("fruits_poisons").metadata["name"] == "flatland_ma_v1"


# -- finished agents --------------------------------------------------------------------


def test_actions_for_finished_agents_are_ignored_and_change_nothing():
    full = flatland_ma.parallel_env("fruits_poisons_multi", **EARLY_EXIT)
    live_only = flatland_ma.parallel_env("fruits_poisons_multi", **EARLY_EXIT)
    a, _ = full.reset(seed=2)  # an agent reaches the zone at the fourth step
    b, _ = live_only.reset(seed=2)
    rng = np.random.default_rng(1)
    finished_seen = False
    for _ in range(300):
        actions = {agent: int(rng.integers(3)) for agent in full.possible_agents}
        finished = [agent for agent in full.possible_agents if agent not in full.agents]
        finished_seen = finished_seen or bool(finished)
        for agent in finished:
            actions[agent] = 99  # not even an action: ignored all the same
        a, ra, ta, ua, _ = full.step(actions)
        b, rb, tb, ub, _ = live_only.step({k: actions[k] for k in live_only.agents})
        assert ra == rb and ta == tb and ua == ub and a.keys() == b.keys()
        for agent in a:
            np.testing.assert_array_equal(a[agent], b[agent])
        if not full.agents:
            break
    assert finished_seen and not full.agents


def test_names_that_were_never_agents_still_raise():
    env = flatland_ma.parallel_env("fruits_poisons_multi", **EARLY_EXIT)
    env.reset(seed=0)
    before = env.state()
    actions = {agent: 0 for agent in env.agents}
    with pytest.raises(ValueError, match="'agent_7', which is not a live agent"):
        env.step({**actions, "agent_7": 0})
    with pytest.raises(ValueError, match="no action given for live agent 'agent_2'"):
        env.step({a: 0 for a in env.agents if a != "agent_2"})
    np.testing.assert_array_equal(env.state(), before)
    relay = flatland_ma.parallel_env("plate_relay")
    relay.reset(seed=0)
    with pytest.raises(ValueError, match="'agent_0', which is not a live agent"):
        relay.step({"scout_0": 0, "runner_0": 0, "agent_0": 0})


# -- render modes -----------------------------------------------------------------------


def test_render_modes_list_human_only_with_pygame():
    import importlib.util

    has_pygame = importlib.util.find_spec("pygame") is not None
    assert ("human" in RENDER_MODES) == has_pygame and "rgb_array" in RENDER_MODES
    assert flatland_ma.parallel_env("fruits_poisons").metadata["render_modes"] == RENDER_MODES
    assert gymnasium.make(FRUITS).metadata["render_modes"] == RENDER_MODES
    assert available_render_modes() == RENDER_MODES


WITHOUT_PYGAME = textwrap.dedent(
    """
    import sys, warnings
    sys.modules["pygame"] = None  # as on a base install: pygame cannot be imported
    import gymnasium
    from gymnasium.utils.env_checker import check_env
    from pettingzoo.test import render_test
    import flatland_ma

    env = gymnasium.make("flatland_ma/FruitsPoisons-v0")
    assert env.metadata["render_modes"] == ["rgb_array"], env.metadata
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    render_test(lambda render_mode=None: flatland_ma.env("fruits_poisons_multi",
                                                          render_mode=render_mode))
    assert flatland_ma.parallel_env("plate_relay").metadata["render_modes"] == ["rgb_array"]
    human = flatland_ma.parallel_env("fruits_poisons", render_mode="human")
    human.reset(seed=0)
    try:
        human.render()
    except ImportError as err:  # the window needs pygame, and says so
        assert "pip install pygame" in str(err) and ".[render]" in str(err), err
    else:
        raise AssertionError("a window opened without pygame")
    print("ok")
    """
)


def test_without_pygame_check_env_and_render_test_pass():
    done = subprocess.run(
        [sys.executable, "-c", WITHOUT_PYGAME],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=Path(__file__).resolve().parents[2],
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().endswith("ok")


# -- one Discrete action for channel scenarios ------------------------------------------


def test_channel_actions_become_one_discrete_action_and_decode_back():
    env = DiscreteActions(flatland_ma.parallel_env("signal_rooms"))
    plain = flatland_ma.parallel_env("signal_rooms")
    for agent in env.possible_agents:
        space = env.action_space(agent)
        assert space is env.action_space(agent) and space == gymnasium.spaces.Discrete(6)
        decoded = [tuple(env.decode(agent, i)) for i in range(space.n)]
        assert len(set(decoded)) == space.n
        assert all(plain.action_space(agent).contains(np.array(d)) for d in decoded)
        assert [env.encode(agent, d) for d in decoded] == list(range(space.n))
        assert tuple(env.decode(agent, 5)) == (2, 1)  # the move first, the word last
    a, _ = env.reset(seed=4)
    b, _ = plain.reset(seed=4)
    rng = np.random.default_rng(2)
    for _ in range(60):
        indices = {agent: int(rng.integers(6)) for agent in env.agents}
        a, ra, *_ = env.step(indices)
        b, rb, *_ = plain.step({k: env.decode(k, i) for k, i in indices.items()})
        assert ra == rb
        for agent in a:
            np.testing.assert_array_equal(a[agent]["messages"], b[agent]["messages"])
        if not env.agents:
            break


@pytest.mark.parametrize("bad", [6, -1, 2.5, "1", True, np.array([1, 0])])
def test_a_bad_discrete_action_names_the_agent_and_changes_nothing(bad):
    env = DiscreteActions(flatland_ma.parallel_env("signal_rooms"))
    env.reset(seed=0)
    before = env.state()
    with pytest.raises(ValueError, match=r"'seeker_0'.*Discrete\(6\)"):
        env.step({"guide_0": 0, "seeker_0": bad})
    np.testing.assert_array_equal(env.state(), before)
    env.step({"guide_0": np.int64(3), "seeker_0": np.array(4)})  # numpy integers are fine


def test_agents_without_multidiscrete_actions_keep_their_spaces():
    plain = flatland_ma.parallel_env("plate_relay")
    env = DiscreteActions(flatland_ma.parallel_env("plate_relay"))
    assert all(env.action_space(a) == plain.action_space(a) for a in env.possible_agents)
    words = flatland_ma.parallel_env("signal_rooms", agent={"actions": "continuous"})
    assert isinstance(DiscreteActions(words).action_space("seeker_0"), gymnasium.spaces.Box)


def test_discrete_actions_pass_pettingzoos_checkers():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(DiscreteActions(flatland_ma.parallel_env("signal_rooms")), 100)
        aec = discrete_aec_env("signal_rooms", flatten=True)
        ignore_known_warnings(aec)
        api_test(aec, num_cycles=100)


def test_nothing_below_the_integrations_imports_them():
    package = Path(flatland_ma.__file__).parent
    wrong = []
    for path in package.rglob("*.py"):
        if path.relative_to(package).parts[0] in ("integrations", "studio"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            wrong += [f"{path}: {n}" for n in names if n.startswith("flatland_ma.integrations")]
    assert wrong == []
