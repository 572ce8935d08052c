"""The ecosystem's conventions, through the real entry points: ``max_episode_steps`` for
``gymnasium.make``, ``max_cycles`` for PettingZoo, ``TypeError`` for unknown keywords,
``record --out clip.mp4`` and ``--version``."""

import importlib.metadata
import importlib.util
import pickle
import subprocess
import sys
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import api_test, parallel_api_test

import flatland_ma
from flatland_ma.cli import main
from flatland_ma.envs.gym import FlatlandGymEnv
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.render import video
from flatland_ma.scenario.errors import ScenarioError, UnknownKeywordError

FRUITS = "flatland_ma/FruitsPoisons-v0"
ROTATE = 1  # rotating in place never ends an episode of fruits_poisons


def steps_to_end(env, limit: int = 5_000) -> tuple[int, bool]:
    """Steps of a Gymnasium env until it terminates or truncates, and whether it truncated."""
    env.reset(seed=0)
    for step in range(1, limit + 1):
        _, _, terminated, truncated, _ = env.step(ROTATE)
        if terminated or truncated:
            return step, truncated
    return limit, False


# -- max_episode_steps (Gymnasium) ------------------------------------------------------


@pytest.mark.parametrize(
    ("env_id", "scenario"),
    [(FRUITS, "fruits_poisons"), ("flatland_ma/ExploreGoal-v0", "explore_goal")],
)
def test_each_id_is_registered_with_its_scenarios_step_limit(env_id, scenario):
    limit = flatland_ma.load_scenario(scenario).episode.max_steps
    assert gymnasium.spec(env_id).max_episode_steps == limit
    env = gymnasium.make(env_id)
    assert env.spec.max_episode_steps == limit
    env.close()


def test_make_without_max_episode_steps_truncates_at_the_scenarios_limit():
    assert steps_to_end(gymnasium.make(FRUITS)) == (500, True)


@pytest.mark.parametrize("max_steps", [7, 1000])
def test_make_honours_max_episode_steps_longer_or_shorter(max_steps):
    env = gymnasium.make(FRUITS, max_episode_steps=max_steps)
    assert env.spec.max_episode_steps == max_steps
    assert steps_to_end(env) == (max_steps, True)


def test_under_make_only_the_time_limit_truncates():
    env = gymnasium.make(FRUITS, max_episode_steps=-1)  # Gymnasium's "no TimeLimit"
    assert env.spec.max_episode_steps is None
    assert steps_to_end(env, limit=800) == (800, False)


def test_a_gym_env_built_directly_truncates_at_the_scenarios_limit():
    assert steps_to_end(FlatlandGymEnv("fruits_poisons")) == (500, True)
    assert steps_to_end(FlatlandGymEnv("fruits_poisons", episode={"max_steps": 30})) == (30, True)


def test_under_make_the_episode_length_is_set_by_max_episode_steps_only():
    with pytest.raises(TypeError, match="max_episode_steps"):
        gymnasium.make(FRUITS, episode={"max_steps": 30})
    with pytest.raises(TypeError, match="max_episode_steps"):
        gymnasium.make(FRUITS, max_cycles=30)


def test_check_env_passes_made_and_built_directly():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gymnasium.make(FRUITS, max_episode_steps=1000).unwrapped)
        # Built directly, the env has no spec for the checker to re-make it from.
        warnings.filterwarnings("ignore", ".*Not able to test alternative render modes")
        check_env(FlatlandGymEnv("fruits_poisons"))


def test_a_made_env_keeps_its_missing_step_limit_through_pickling():
    env = gymnasium.make(FRUITS, max_episode_steps=1000)
    env.reset(seed=0)
    copy = pickle.loads(pickle.dumps(env.unwrapped))
    assert copy.parallel_env.step_limit is None
    for _ in range(600):
        assert copy.step(ROTATE)[3] is False


# -- max_cycles (PettingZoo) ------------------------------------------------------------


def test_parallel_env_max_cycles_sets_the_episode_length():
    env = flatland_ma.parallel_env("fruits_poisons_multi", max_cycles=12)
    assert env.spec.episode.max_steps == 12
    env.reset(seed=0)
    cycles = 0
    while env.agents:
        _, _, _, truncations, _ = env.step({a: ROTATE for a in env.agents})
        cycles += 1
    assert cycles == 12 and all(truncations.values())
    parallel_api_test(flatland_ma.parallel_env("fruits_poisons_multi", max_cycles=12))


def test_aec_env_max_cycles_sets_the_episode_length():
    env = flatland_ma.env("fruits_poisons_multi", max_cycles=9)
    env.reset(seed=0)
    acted = 0
    for _ in env.agent_iter():
        _, _, terminated, truncated, _ = env.last()
        acted += not (terminated or truncated)
        env.step(None if terminated or truncated else ROTATE)
    assert acted == 9 * len(env.possible_agents)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        api_test(flatland_ma.env("fruits_poisons_multi", max_cycles=9), num_cycles=20)


def test_max_cycles_and_episode_max_steps_together_are_refused():
    with pytest.raises(TypeError, match="max_cycles"):
        flatland_ma.parallel_env("fruits_poisons", max_cycles=5, episode={"max_steps": 6})


# -- unknown keywords -------------------------------------------------------------------


@pytest.mark.parametrize(
    "make",
    [
        lambda: flatland_ma.parallel_env("fruits_poisons", frameskip=1),
        lambda: flatland_ma.env("fruits_poisons", frameskip=1),
        lambda: gymnasium.make(FRUITS, frameskip=1),
        lambda: FlatlandParallelEnv("fruits_poisons", max_cycles=20, frameskip=1),
    ],
    ids=["parallel_env", "env", "gymnasium.make", "with_max_cycles"],
)
def test_an_unknown_keyword_is_a_type_error_naming_the_key_and_the_file(make):
    with pytest.raises(TypeError) as info:
        make()
    assert isinstance(info.value, ScenarioError)
    assert "'frameskip'" in str(info.value) and "fruits_poisons.yaml" in str(info.value)


def test_a_probe_for_an_optional_keyword_falls_back():
    try:  # as TorchRL's GymEnv probes for frameskip
        env = gymnasium.make(FRUITS, frameskip=1)
    except TypeError:
        env = gymnasium.make(FRUITS)
    assert env.reset(seed=0)[0].shape == env.observation_space.shape


def test_the_unknown_keyword_error_lists_its_problems():
    with pytest.raises(UnknownKeywordError) as info:
        flatland_ma.parallel_env("fruits_poisons", n_agent=2, frameskip=1)
    assert [p.path for p in info.value.problems] == [("n_agent",), ("frameskip",)]
    assert "did you mean 'n_agents'" in str(info.value)


@pytest.mark.parametrize(
    "overrides",
    [{"episode": {"max_steps": 0}}, {"agent": {"camra": {}}}, {"n_agents": "two"}],
    ids=["bad_value", "unknown_nested_key", "bad_top_level_value"],
)
def test_bad_values_and_nested_keys_stay_value_errors(overrides):
    with pytest.raises(ScenarioError) as info:
        flatland_ma.parallel_env("fruits_poisons", **overrides)
    assert isinstance(info.value, ValueError) and not isinstance(info.value, TypeError)


# -- record --out clip.mp4 --------------------------------------------------------------


def read_mp4(path) -> list[np.ndarray]:
    import av

    with av.open(str(path)) as container:
        return [frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)]


def test_record_writes_an_mp4_whose_frames_read_back(tmp_path):
    out = tmp_path / "clip.mp4"
    args = ["record", "fruits_poisons", "--steps", "6", "--every", "2", "--out", str(out)]
    assert main(args) == 0
    env = flatland_ma.parallel_env("fruits_poisons", render_mode="rgb_array")
    env.reset(seed=0)
    frames = read_mp4(out)
    assert len(frames) == 4  # the first frame and one in two of 6 steps
    assert all(frame.shape == env.render().shape for frame in frames)
    assert out.with_suffix(".png").exists()


def test_an_mp4_of_odd_size_gains_one_row_and_column(tmp_path):
    frames = [np.full((33, 45, 3), value, np.uint8) for value in (40, 200, 120)]
    got = read_mp4(video.save_mp4(frames, tmp_path / "odd.mp4", fps=10))
    assert [f.shape for f in got] == [(34, 46, 3)] * 3
    assert [int(round(f.mean())) for f in got] == pytest.approx([40, 200, 120], abs=3)


@pytest.mark.parametrize("name", ["clip.avi", "clip.webm", "clip"])
def test_record_refuses_an_unwritable_suffix_before_rendering(tmp_path, capsys, monkeypatch, name):
    calls = []
    monkeypatch.setattr(FlatlandParallelEnv, "reset", lambda *a, **k: calls.append("reset"))
    monkeypatch.setattr(FlatlandParallelEnv, "render", lambda *a, **k: calls.append("render"))
    assert main(["record", "fruits_poisons", "--out", str(tmp_path / name)]) == 2
    assert calls == [] and list(tmp_path.iterdir()) == []
    assert ".gif, .png, .mp4" in capsys.readouterr().err


def test_an_mp4_without_pyav_is_refused_with_the_extra_to_install(tmp_path, monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "av" else real(name, *a)
    )
    with pytest.raises(ValueError, match=r"pip install av; .*pip install -e '\.\[render\]'"):
        video.check_writable(tmp_path / "clip.mp4")
    video.check_writable(tmp_path / "clip.gif")


# -- --version --------------------------------------------------------------------------


def test_version_comes_from_the_package_metadata():
    assert flatland_ma.__version__ == importlib.metadata.version("flatland-ma")
    out = subprocess.run(
        [sys.executable, "-m", "flatland_ma.cli", "--version"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert out.strip() == f"flatland-ma {flatland_ma.__version__}"


def test_version_in_process(capsys):
    assert main(["--version"]) == 0  # main returns the status the process exits with
    assert capsys.readouterr().out.strip() == f"flatland-ma {flatland_ma.__version__}"
