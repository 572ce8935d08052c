"""The benchmark page's section on the imitation probe: a row per probed task of its
current version, PPO's standard figures beside the imitator's, and what they say."""

from __future__ import annotations

from baselines.benchmark.within_reach import imitation_section, reading


def _record(version: int, normalised: float, **more) -> dict:
    rounds = [{"steps_kept": 100, "return": 1.0}, {"steps_kept": 200, "return": 2.0}]
    return {"version": version, "rounds": rounds, "held_out": 5.0, "normalised": normalised,
            "cpu_seconds": 60.0, **more}  # fmt: skip


def test_each_current_task_has_its_row_and_an_older_version_is_named_apart():
    records = {
        "scent_rooms": _record(0, 0.85),
        "maze_goal": _record(
            0, 0.3, then_ppo={"held_out": 9.0, "normalised": 0.9, "agent_steps": 1000}
        ),
        "signal_rooms": _record(0, 0.9),
    }
    rows = [
        {
            "task": "scent_rooms",
            "normalised": {"iqm": 0.1, "low": 0.05, "high": 0.12},
            "scripted": {"iqm": 91.7},
        }
    ]
    lines = imitation_section(records, rows)
    row = next(line for line in lines if line.startswith("| `scent_rooms`"))
    assert "91.7" in row and "0.1 (0.05 to 0.12)" in row and "5 (0.85)" in row
    assert "200 steps" in row and "PPO does not find" in row
    maze = next(line for line in lines if line.startswith("| `maze_goal`"))
    assert "9 (0.9)" in maze and "PPO 1,000 agent-steps" in maze and "keeps the way" in maze
    assert not any(line.startswith("| `signal_rooms`") for line in lines)  # it is version 2
    assert "not shown: `signal_rooms`" in lines[-2]


def test_the_reading_follows_the_two_scores():
    assert reading(0.8, 0.1).startswith("seen enough: PPO does not find")
    assert reading(0.8, 0.9) == "seen enough"
    assert reading(0.8, None) == "seen enough"
    assert reading(0.2, 0.1).startswith("not imitated")
    assert reading(0.2, 0.1, 0.7).startswith("PPO keeps the way")
    assert reading(0.2, 0.6, 0.7) == reading(0.2, 0.6)  # PPO from scratch does it already
    assert reading(0.2, 0.6).startswith("learnt from the reward")
    assert reading(0.33, 0.0, 0.0).startswith("shown but not held")
