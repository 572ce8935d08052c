"""Same seed and same actions give identical trajectories, in one process and across
processes (with different hash seeds)."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flatland_ma
from tests.rollouts import rollout_digest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("scenario", flatland_ma.list_scenarios())
def test_parallel_rollouts_of_600_steps_repeat_exactly(scenario):
    first = rollout_digest(scenario, seed=3, steps=600)
    assert rollout_digest(scenario, seed=3, steps=600) == first
    assert rollout_digest(scenario, seed=4, steps=600) != first


def test_reset_with_a_seed_forgets_the_past():
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    env.reset(seed=11)
    for _ in range(137):
        env.step({a: 0 for a in env.agents})
    obs_again, _ = env.reset(seed=11)
    fresh, _ = flatland_ma.parallel_env("fruits_poisons_multi").reset(seed=11)
    for a in fresh:
        np.testing.assert_array_equal(obs_again[a], fresh[a])


def test_unseeded_resets_differ_but_continue_the_seeded_stream():
    env = flatland_ma.parallel_env("fruits_poisons")
    first, _ = env.reset(seed=5)
    second, _ = env.reset()
    assert not np.array_equal(first["agent_0"], second["agent_0"])
    other = flatland_ma.parallel_env("fruits_poisons")
    other.reset(seed=5)
    np.testing.assert_array_equal(other.reset()[0]["agent_0"], second["agent_0"])


@pytest.mark.parametrize(
    "scenario", ["fruits_poisons_multi", "maze_goal", "obstacle_forest", "tug_of_war"]
)
def test_rollouts_match_across_processes(scenario):
    code = (
        "from tests.rollouts import rollout_digest;"
        f"print(rollout_digest({scenario!r}, seed=9, steps=700))"
    )
    digests = set()
    for hash_seed in ("1", "2"):
        env = dict(os.environ, PYTHONHASHSEED=hash_seed)
        out = subprocess.run(
            [sys.executable, "-c", code],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
        digests.add(out.stdout.strip())
    digests.add(rollout_digest(scenario, seed=9, steps=700))
    assert len(digests) == 1
