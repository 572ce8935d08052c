"""The channel: words said with a step's actions are heard in the observations that step
returns, by the agents in range (and of the team, if asked) and not by the others; the
action and observation spaces, the state, determinism, pickling and the batched env carry
them; and a task that needs them scores better with them."""

import pickle

import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence

import flatland_ma
from flatland_ma.agents.actuators import InvalidActionError
from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.policies import Follower, Heeder, Signaller, evaluate
from flatland_ma.scenario.errors import ScenarioError

CHANNEL = {"tokens": 2, "vocabulary": 3, "range": 100.0}


def _env(**channel):
    return flatland_ma.parallel_env("fruits_poisons_multi", channel={**CHANNEL, **channel})


def _place(env, positions):
    for body, (x, y) in zip(env.episode.bodies, positions):
        env.episode.world.place(body, x, y, 0.0)


def _say(env, words):
    """Every live agent turns on the spot and says ``words[agent index]``."""
    return {a: np.array([1, *words[env.possible_agents.index(a)]]) for a in env.agents}


def _heard(row, vocabulary=3):
    """The words of a heard row (None if not heard)."""
    if row[0] == 0:
        return None
    return tuple(int(np.argmax(row[1 + j * vocabulary : 1 + (j + 1) * vocabulary])) for j in (0, 1))


def test_words_said_at_a_step_are_heard_in_its_observations_by_agents_in_range():
    env = _env()
    observations, _ = env.reset(seed=0)
    assert not any(observations[a]["messages"].any() for a in env.agents)  # nobody spoke yet
    # agent_1 is 60 from agent_0, agent_2 150 away, agent_3 far from everyone.
    _place(env, [(100, 100), (160, 100), (250, 100), (350, 320)])
    words = [(0, 1), (2, 2), (1, 0), (2, 1)]
    observations, *_ = env.step(_say(env, words))
    heard = {a: [_heard(row) for row in observations[a]["messages"]] for a in env.agents}
    assert heard["agent_0"] == [(0, 1), (2, 2), None, None]
    assert heard["agent_1"] == [(0, 1), (2, 2), (1, 0), None]  # 90 from agent_2
    assert heard["agent_2"] == [None, (2, 2), (1, 0), None]
    assert heard["agent_3"] == [None, None, None, (2, 1)]  # only itself
    # The next step's words replace them.
    observations, *_ = env.step(_say(env, [(1, 1)] * 4))
    assert _heard(observations["agent_0"]["messages"][1]) == (1, 1)


def test_teammates_only_hear_each_other_when_the_channel_is_for_teams():
    teams = [{"name": "red", "size": 2}, {"name": "blue", "size": 2}]
    env = flatland_ma.parallel_env(
        "fruits_poisons_multi", teams=teams, channel={**CHANNEL, "range": None, "team": True}
    )
    env.reset(seed=1)
    observations, *_ = env.step(_say(env, [(1, 1)] * 4))
    rows = observations["red_0"]["messages"]  # agents of teams are named by team
    assert rows[:2, 0].tolist() == [1, 1] and rows[2:, 0].tolist() == [0, 0]
    with pytest.raises(ScenarioError, match="channel.team"):
        flatland_ma.load_scenario("fruits_poisons_multi", channel={"team": True})


def test_an_agent_whose_episode_ended_is_silent():
    exit_ = {"name": "exit", "color": "white", "terminal": True, "respawn": "never"}
    env = flatland_ma.parallel_env(
        "fruits_poisons", n_agents=4, channel={**CHANNEL, "range": None},
        items=[{**exit_, "positions": [[250, 250]]}],
    )  # fmt: skip
    env.reset(seed=2)
    _place(env, [(60, 60), (120, 60), (180, 60), (250, 250)])  # agent_3 on the exit
    observations, _, terminations, *_ = env.step(_say(env, [(1, 2)] * 4))
    assert terminations["agent_3"] and env.agents == ["agent_0", "agent_1", "agent_2"]
    assert observations["agent_0"]["messages"][3].sum() == 0  # its last words are lost
    observations, *_ = env.step(_say(env, [(2, 0)] * 4))
    assert observations["agent_0"]["messages"][3].sum() == 0
    assert _heard(observations["agent_0"]["messages"][2]) == (2, 0)


def test_spaces_and_names_with_a_channel():
    env = _env()
    assert str(env.action_space("agent_0")) == "MultiDiscrete([3 3 3])"
    assert env.action_names("agent_0")[-2:] == ("say_0", "say_1")
    assert env.action_index("say_1", "agent_0") == 2 and env.action_index("rotate_left") == 1
    assert env.observation_space("agent_0")["messages"].shape == (4, 1 + 2 * 3)
    continuous = flatland_ma.parallel_env(
        "fruits_poisons_multi", agent={"actions": "continuous"}, channel=CHANNEL
    )
    assert continuous.action_space("agent_0").shape == (3 + 2,)
    actuator = continuous.actuators[0]
    # [-1, 1] cut into three equal bins.
    said = [
        actuator.said(np.array([0, 0, 0, x, y])) for x, y in ((-1, -0.34), (-0.32, 0.3), (0.34, 1))
    ]
    assert [w.tolist() for w in said] == [[0, 0], [1, 1], [2, 2]]


@pytest.mark.parametrize(
    "action, reason",
    [
        (np.array([0, 3, 0]), "out of range"),
        (np.array([0, 1]), "shape"),
        (np.array([0.0, 1.0, 1.0]), "integers"),
        (1, "shape"),
    ],
)
def test_bad_words_are_refused_and_change_nothing(action, reason):
    env = _env()
    env.reset(seed=3)
    before = env.state()
    actions = _say(env, [(0, 0)] * 4)
    actions["agent_2"] = action
    with pytest.raises(InvalidActionError, match=f"agent_2.*{reason}"):
        env.step(actions)
    assert np.array_equal(env.state(), before) and env.num_steps == 0


def test_words_are_in_the_state():
    env = _env()
    env.reset(seed=4)
    labels = env.state_labels
    assert labels[-8:] == tuple(f"agent_{i}.say_{j}" for i in range(4) for j in (0, 1))
    assert not env.state()[-8:].any()  # silence
    env.step(_say(env, [(0, 2), (1, 1), (2, 0), (0, 0)]))
    np.testing.assert_allclose(env.state()[-8:], np.array([1, 3, 2, 2, 3, 1, 1, 1]) / 3)


def test_same_seed_and_actions_give_the_same_words_and_pickles_continue_them():
    def run(env, steps=60):
        env.reset(seed=5)
        rng = np.random.default_rng(0)
        out = []
        for _ in range(steps):
            actions = {a: rng.integers([3, 3, 3]) for a in env.agents}
            out.append(env.step(actions))
        return out

    a, b = _env(), _env()
    assert data_equivalence(run(a), run(b), exact=True)
    copy = pickle.loads(pickle.dumps(a))
    rng = np.random.default_rng(1)
    for _ in range(30):
        actions = {agent: rng.integers([3, 3, 3]) for agent in a.agents}
        assert data_equivalence(a.step(actions), copy.step(actions), exact=True)


def test_the_batched_env_carries_the_words_as_separate_envs_do():
    batch = BatchedParallelEnv("fruits_poisons_multi", num_worlds=2, channel=CHANNEL)
    envs = [_env() for _ in range(2)]
    observations, _ = batch.reset(seed=7)
    for k, env in enumerate(envs):
        env.reset(seed=7 + k)
    rng = np.random.default_rng(2)
    for _ in range(20):
        actions = rng.integers([3, 3, 3], size=(8, 3))
        observations, *_ = batch.step(actions)
        for k, env in enumerate(envs):
            alone, *_ = env.step({f"agent_{i}": actions[4 * k + i] for i in range(4)})
            for i in range(4):
                np.testing.assert_array_equal(
                    observations["messages"][4 * k + i], alone[f"agent_{i}"]["messages"]
                )


@pytest.mark.parametrize("scenario", ["signal_rooms", "signal_maps"])
def test_signalling_scores_better_with_the_channel_than_without(scenario):
    """The guide's words send the seeker straight to the goal's room; without them it
    guesses, and a wrong guess costs the walk to the other room (scores in the files)."""

    def score(**overrides):
        env = flatland_ma.parallel_env(scenario, **overrides)

        def make(agent):
            if agent == "guide_0":
                return Signaller(env, agent)
            return Follower(env, agent, seed=1)

        return evaluate(env, make, episodes=8)

    told, guessing = score(), score(channel=None)
    assert all(info["seeker_0"]["goal"] == 1 for info in told.infos)
    assert told.mean > guessing.mean + 0.3
    assert min(told.returns) > min(guessing.returns) + 0.5


class _LateTruth(Signaller):
    """Names the wrong room for its first ``lies`` steps, then the goal's."""

    def __init__(self, env, agent, lies=4):
        super().__init__(env, agent)
        self.first_lies = self.lies = lies

    def reset(self):
        self.lies = self.first_lies

    def act(self, observation=None):
        action = np.array(super().act(observation))
        if self.lies > 0:
            self.lies -= 1
            action[-1] = 1 - action[-1]  # two rooms: the other word
        return action


def test_the_heeder_goes_where_most_words_send_it_and_the_follower_the_first():
    """Beside a guide that first names the wrong room and then the right one, the heeder
    turns once the right room has been named most often and finds the goal in every
    episode; the follower keeps to the first word and mostly runs out of time on the way
    to the second room."""

    def run(seeker):
        env = flatland_ma.parallel_env("signal_rooms")

        def make(agent):
            return _LateTruth(env, agent) if agent == "guide_0" else seeker(env, agent, seed=1)

        return evaluate(env, make, episodes=6)

    heeded, followed = run(Heeder), run(Follower)
    assert all(info["seeker_0"]["goal"] == 1 for info in heeded.infos)
    assert sum(info["seeker_0"]["goal"] for info in followed.infos) <= 3
    assert heeded.mean > followed.mean + 3.0


def test_the_heeder_counts_every_word_until_it_tries_a_room():
    """The heeder's room is the one named most often so far, a tie going to the latest
    word; once it has tried a room, words no longer move it."""
    env = flatland_ma.parallel_env("signal_rooms")
    env.reset(seed=3)
    heeder = Heeder(env, "seeker_0", seed=0)
    heeder.reset()

    def heard(word):
        messages = np.zeros((2, 3), np.float32)
        messages[0, 0], messages[0, 1 + word] = 1.0, 1.0
        return {"messages": messages}

    rooms = []
    for word in (0, 0, 1, 1, 1, 0):
        heeder.act(heard(word))
        rooms.append(heeder.room)
    assert rooms == [0, 0, 0, 1, 1, 0]  # the latest word alone would give 0, 0, 1, 1, 1, 0
    heeder.tried.add(0)
    heeder.act(heard(1))
    assert list(heeder.tally) == [3, 3]
