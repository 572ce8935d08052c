"""Keyboard play: keys to actions, the game loop driven by posted events or a key script on
SDL's dummy driver, Tab, the scores file, and the refusal without a display."""

import csv
import os
import subprocess
import sys

import numpy as np
import pytest

import flatland_ma
from flatland_ma.cli import main
from flatland_ma.play import KeyMap, Keys, PygameKeys, ScriptedKeys, Session, missing_display, play
from flatland_ma.play.session import SCORE_COLUMNS
from flatland_ma.policies.idle import IdlePolicy

# -- keys to actions ----------------------------------------------------------------------


def test_arrows_drive_the_papers_three_actions():
    names = flatland_ma.parallel_env("fruits_poisons").action_names()
    keys = KeyMap(names, discrete=True)
    assert [keys.action({k}) for k in ("up", "left", "right")] == [0, 1, 2]
    assert keys.action(set()) is None and keys.action({"x", "tab"}) is None
    assert keys.action({"right", "up"}) == 0  # several held: the first in action order
    assert keys.keys == {"up", "left", "right"}


def test_every_named_action_of_a_body_with_parts_has_its_key():
    names = flatland_ma.parallel_env("tug_of_war").action_names()
    keys = KeyMap(names, discrete=True)
    expected = {
        "up": "forward",
        "space": "stay",
        "q": "head_left",
        "e": "head_right",
        "z": "arm_left",
        "x": "arm_right",
        "g": "grasp",
        "r": "release",
    }
    for key, name in expected.items():
        action = keys.action({key})
        assert isinstance(action, int) and names[action] == name
    assert {b.label for b in keys.bindings} == set(names)  # nothing left without a key


def test_keys_set_the_entries_of_a_continuous_action():
    env = flatland_ma.parallel_env("tug_of_war", agent={"actions": "continuous"})
    names = env.action_names()
    assert names == ("longitudinal", "lateral", "angular", "head", "arm", "arm_grip")
    keys = KeyMap(names, discrete=False)
    np.testing.assert_array_equal(keys.action({"up", "left"}), [1, 0, 1, 0, 0, 0])
    np.testing.assert_array_equal(keys.action({"down", "d", "right"}), [-1, -1, -1, 0, 0, 0])
    np.testing.assert_array_equal(keys.action({"q", "x", "g"}), [0, 0, 0, 1, -1, 1])
    np.testing.assert_array_equal(keys.action({"up", "down"}), np.zeros(6))  # they cancel
    np.testing.assert_array_equal(keys.action({"space"}), np.zeros(6))  # a step of nothing
    assert keys.action({"tab"}) is None
    assert env.action_space("red_0").contains(keys.action({"up", "e", "r"}))


def test_a_key_script_holds_keys_for_frames_then_quits():
    keys = ScriptedKeys("up*3 tab wait*2 up+left")
    frames = [keys.poll([]) for _ in range(8)]
    assert frames[0] == Keys(frozenset({"up"}), frozenset({"up"}))
    assert frames[1] == frames[2] == Keys(held=frozenset({"up"}))
    assert frames[3].pressed == {"tab"} and frames[4] == frames[5] == Keys()
    assert frames[6].down == {"up", "left"}
    assert frames[7].quit
    with pytest.raises(ValueError, match="fewer than one frame"):
        ScriptedKeys("up*0")


def test_posted_pygame_events_are_held_keys_until_released():
    pygame = pytest.importorskip("pygame")
    pygame.display.init()
    try:
        pygame.display.set_mode((32, 32))
        keys = PygameKeys()
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_UP))
        first = keys.poll(pygame.event.get())
        assert first.pressed == {"up"} and first.held == {"up"}
        assert keys.poll(pygame.event.get()) == Keys(held=frozenset({"up"}))
        pygame.event.post(pygame.event.Event(pygame.KEYUP, key=pygame.K_UP))
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_TAB))
        pygame.event.post(pygame.event.Event(pygame.KEYUP, key=pygame.K_TAB))
        tapped = keys.poll(pygame.event.get())
        assert tapped.held == set() and tapped.down == {"tab"}  # a tap still counts once
        pygame.event.post(pygame.event.Event(pygame.QUIT))
        assert keys.poll(pygame.event.get()).quit
    finally:
        pygame.display.quit()


# -- the session ---------------------------------------------------------------------------


def held(*names: str) -> Keys:
    return Keys(held=frozenset(names))


def test_the_keys_drive_one_agent_and_tab_hands_them_to_the_next():
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    session = Session(env, "fruits_poisons_multi", seed=3, others="idle")
    start = [b.body.position for b in env.running.bodies]
    for _ in range(15):
        session.advance(held("up"))
    moved = [(b.body.position - p).length for b, p in zip(env.running.bodies, start)]
    assert moved[0] > 10 and max(moved[1:]) < 1.0  # the idle others stayed put
    assert session.advance(Keys(pressed=frozenset({"tab"})))
    assert session.agent == "agent_1" and env.num_steps == 15  # Tab alone takes no step
    before = env.running.bodies[1].body.position
    for _ in range(10):
        session.advance(held("up"))
    assert (env.running.bodies[1].body.position - before).length > 5
    assert session.tallies["agent_0"].steps == 15 and session.tallies["agent_1"].steps == 10
    assert not session.advance(Keys(pressed=frozenset({"escape"})))
    assert session.stopped and session.finished == []  # an unfinished episode is not scored


def test_idle_others_keep_still_in_every_action_mode():
    for actions in ("discrete", "continuous"):
        env = flatland_ma.parallel_env("fruits_poisons_multi", agent={"actions": actions})
        env.reset(seed=0)
        idle = IdlePolicy(env, "agent_1")
        start = env.running.bodies[1].body.position
        for _ in range(20):
            env.step({a: idle.act() for a in env.agents})
        assert (env.running.bodies[1].body.position - start).length < 1e-6
    env = flatland_ma.parallel_env("tug_of_war")
    assert IdlePolicy(env, "red_1").act() == env.action_index("stay", "red_1")


def test_each_episodes_score_is_appended_to_the_scores_file(tmp_path):
    scores = tmp_path / "scores.csv"
    env = flatland_ma.parallel_env("fruits_poisons", max_cycles=40)
    session = Session(env, "fruits_poisons", seed=15, episodes=2, scores=scores)
    for _ in range(40):
        session.advance(held("up"))
    assert session.episode == 1 and env.num_steps == 0  # the second episode has begun
    # The same 40 steps on the same seed, without the session: the score to expect.
    check = flatland_ma.parallel_env("fruits_poisons", max_cycles=40)
    check.reset(seed=15)
    expected = sum(check.step({"agent_0": 0})[1]["agent_0"] for _ in range(40))
    assert expected == 30  # this seed's path meets fruits: a score worth checking
    with scores.open() as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0]) == list(SCORE_COLUMNS)
    assert [(r["scenario"], r["seed"], r["agent"], r["steps"]) for r in rows] == [
        ("fruits_poisons", "15", "agent_0", "40")
    ]
    assert float(rows[0]["score"]) == expected
    for _ in range(40):
        session.advance(held("left"))
    assert session.done and not session.advance(held("up"))
    with scores.open() as handle:
        rows = list(csv.DictReader(handle))
    assert [r["seed"] for r in rows] == ["15", "16"] and rows[1]["score"] == "0"


def test_an_agent_whose_episode_ends_hands_the_keys_on(monkeypatch):
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    session = Session(env, "fruits_poisons_multi", seed=0, others="idle")
    original = env.advance

    def ending_agent_0():
        live, rewards, terminated, truncated = original()
        terminated[0] = env.num_steps >= 3
        if terminated[0] and 0 in env.live:
            env.live.remove(0)
            env.agents.remove("agent_0")
        return live, rewards, terminated, truncated

    monkeypatch.setattr(env, "advance", ending_agent_0)
    for _ in range(3):
        session.advance(held("up"))
    assert "agent_0" not in env.agents and session.agent == "agent_1"


def test_an_unknown_policy_for_the_others_is_refused():
    with pytest.raises(
        ValueError, match="sniffer, signaller, follower, heeder, random, idle, or a checkpoint"
    ):
        Session(flatland_ma.parallel_env("fruits_poisons_multi"), "x", others="smart")


# -- the window and the command --------------------------------------------------------------


def test_a_speaking_agent_chooses_its_words_by_key_and_says_them_with_each_action():
    env = flatland_ma.parallel_env("signal_maps")
    agent = env.possible_agents[0]
    space = env.action_space(agent)  # MultiDiscrete([moves, words])
    keys = KeyMap.for_space(env.action_names(agent), space)
    assert keys.keys == {"up", "left", "right", "m"}
    np.testing.assert_array_equal(keys.action({"up"}), [0, 0])
    assert keys.press({"m"}) and keys.action({"m"}) is None  # choosing a word is no step
    np.testing.assert_array_equal(keys.action({"left"}), [1, 1])
    assert space.contains(keys.action({"left"}))
    keys.press({"m"})  # round the vocabulary of two
    np.testing.assert_array_equal(keys.action({"right"}), [2, 0])
    assert "m: next word of say_0" in keys.help()


def test_a_continuous_speaker_says_the_middle_of_each_words_bin():
    env = flatland_ma.parallel_env(
        "fruits_poisons", channel={"tokens": 2, "vocabulary": 4}, agent={"actions": "continuous"}
    )
    agent = env.possible_agents[0]
    keys = KeyMap.for_space(env.action_names(agent), env.action_space(agent), 4)
    keys.press({"m"})
    keys.press({"k", "m"})
    action = keys.action({"up"})
    np.testing.assert_allclose(action, [1, 0, 0, 0.25, -0.25])  # words 2 and 1 of 4
    assert env.action_space(agent).contains(action)


@pytest.mark.parametrize("scenario", ["signal_maps", "signal_rooms"])
def test_scenarios_with_a_channel_play_in_a_window(scenario, tmp_path):
    session = play(scenario, seed=0, scores=None, fps=0, script="up*3 m left*2 tab up")
    assert session.env.num_steps == 6 and session.maps["guide_0"].said == [1]


def test_play_in_a_window_from_a_key_script(tmp_path):
    scores, shot = tmp_path / "scores.csv", tmp_path / "window.png"
    session = play(
        "fruits_poisons_multi",
        seed=1,
        others="greedy",
        scores=scores,
        fps=0,
        script="up*6 tab up*4 left*2",
        screenshot=shot,
        overrides={"max_cycles": 12},
    )
    assert [(r["agent"], r["steps"]) for r in session.finished] == [
        ("agent_0", 6),
        ("agent_1", 6),
    ]
    assert scores.read_text().count("\n") == 3  # the header and one row per agent driven
    from PIL import Image

    with Image.open(shot) as image:
        picture = np.asarray(image.convert("RGB"))
    env = flatland_ma.parallel_env("fruits_poisons_multi", render_mode="rgb_array")
    env.reset(seed=1)
    world = env.render()
    assert world is not None
    # The window: the rendered world (same width), and the status bar beneath it.
    assert picture.shape[1] == world.shape[1] and picture.shape[0] > world.shape[0]
    assert picture[world.shape[0] :].max() > 100  # text in the bar


def test_the_play_command_writes_scores_and_a_screenshot(tmp_path, capsys):
    scores, shot = tmp_path / "s.csv", tmp_path / "w.png"
    args = ["play", "fruits_poisons", "--seed", "15", "--fps", "0", "--scores", str(scores)]
    args += ["--keys", "up*40", "--screenshot", str(shot), "--agents", "1"]
    assert main(args) == 0  # 40 of the episode's 500 steps
    assert "left before the episode ended" in capsys.readouterr().out
    assert shot.exists() and not scores.exists()  # nothing finished, nothing written


def test_play_refuses_without_a_display():
    environ = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    environ["SDL_VIDEODRIVER"] = "x11"
    done = subprocess.run(
        [sys.executable, "-m", "flatland_ma.cli", "play", "fruits_poisons"],
        env=environ,
        capture_output=True,
        text=True,
        timeout=600,  # a guard against a hang (waiting for a window), not a time to beat
    )
    assert done.returncode != 0 and "needs a display" in done.stderr


def test_the_display_check_follows_the_environment(monkeypatch):
    monkeypatch.setattr(sys, "platform", "linux")
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER"):
        monkeypatch.delenv(name, raising=False)
    assert "needs a display" in (missing_display() or "")
    monkeypatch.setenv("WAYLAND_DISPLAY", "wayland-0")
    assert missing_display() is None
    monkeypatch.delenv("WAYLAND_DISPLAY")
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    assert missing_display() is None


def test_a_bad_override_or_script_fails_with_a_message(capsys, tmp_path):
    assert main(["play", "fruits_poisons", "--keys", "up*0", "--fps", "0"]) == 2
    assert "fewer than one frame" in capsys.readouterr().err
    blind = ["play", "fruits_poisons_multi", "--sensors", "lidar", "--keys", "up", "--fps", "0"]
    assert main([*blind, "--others", "greedy"]) == 2
    assert "camera" in capsys.readouterr().err  # greedy others need one
    assert main([*blind, "--scores", str(tmp_path / "s.csv")]) == 0  # each a policy that suits
    assert main(["play", "fruits_poisons", "--sensors", "sonar", "--keys", "up"]) == 2
    assert "sonar" in capsys.readouterr().err
