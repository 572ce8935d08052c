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


@pytest.mark.parametrize("area", [None, (60.0, 40.0, 150.0, 120.0)])
def test_a_place_is_drawn_as_a_cell_then_two_uniform_numbers_in_it(area):
    """What ``Placer.sample`` draws from the generator, written out with numpy's
    ``uniform``: a reset or a respawn that drew it otherwise would move every item."""
    from flatland_ma.build.builder import lay_ground
    from flatland_ma.scenario.loader import load_scenario

    placer = lay_ground(load_scenario("fruits_poisons"), np.random.default_rng(0)).placer
    cells, side = placer.candidates(area), placer.grid.cell
    drawn, reference = np.random.default_rng(5), np.random.default_rng(5)
    for _ in range(200):
        x, y = placer.sample(drawn, 1.0, area)
        while True:  # the reference: cell, then x, then y; again while the disc is not free
            i, j = cells[reference.integers(len(cells))]
            rx, ry = (j + reference.uniform(0.0, 1.0)) * side, (i + reference.uniform()) * side
            if area is not None:
                rx, ry = min(max(rx, area[0]), area[2]), min(max(ry, area[1]), area[3])
            if placer.world.is_free(rx, ry, 2.0):
                break
        assert (x, y) == (rx, ry)
    assert drawn.random() == reference.random()  # as many draws taken
