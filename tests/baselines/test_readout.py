"""The readout probe (baselines.benchmark.readout): its labels are the goal's zone as the
scripted guide names it, it learns an answer that the observation shows and not one it
hides, and it refuses what it cannot probe."""

from __future__ import annotations

import json

import numpy as np
import pytest
from gymnasium import spaces

import flatland_ma
from baselines.benchmark import readout
from flatland_ma.policies.signals import Signaller


def test_the_label_is_the_room_the_signaller_names():
    env = flatland_ma.parallel_env("signal_rooms")
    guide = Signaller(env, "guide_0")
    seen = set()
    for seed in range(12):
        env.reset(seed=seed)
        word = int(np.asarray(guide.act()).reshape(-1)[-1])
        assert readout.goal_zone(env) == word
        seen.add(word)
    assert seen == {0, 1}  # both rooms came up


def fake_episodes(labels: np.ndarray, shown: np.ndarray) -> readout.Episodes:
    """Episodes whose observation is a 4-vector carrying ``shown`` in its first entry."""
    observations = np.zeros((len(labels), 4), np.float32)
    observations[:, 0] = shown
    space = spaces.Box(-1.0, 1.0, (4,), np.float32)
    return readout.Episodes(observations, labels, space, ["north", "south"])


def test_the_probe_learns_an_answer_the_observation_shows(monkeypatch, tmp_path):
    labels = np.random.default_rng(0).integers(0, 2, 400)
    monkeypatch.setattr(
        readout, "first_observations", lambda args: fake_episodes(labels, 2.0 * labels - 1.0)
    )
    args = readout.Args(epochs=8, learning_rate=1e-2, json=str(tmp_path / "r.json"))
    figures = readout.main(args)
    assert figures["episodes"] == 400
    assert 0.5 <= figures["chance"] < 0.65
    assert figures["epochs"][-1]["held_out"] == 1.0
    assert json.loads((tmp_path / "r.json").read_text())["zones"] == ["north", "south"]


def test_the_probe_does_not_learn_an_answer_the_observation_hides(monkeypatch):
    rng = np.random.default_rng(1)
    labels = rng.integers(0, 2, 400)
    noise = rng.uniform(-1, 1, 400)  # independent of the labels
    monkeypatch.setattr(readout, "first_observations", lambda args: fake_episodes(labels, noise))
    figures = readout.probe(readout.Args(epochs=8, learning_rate=1e-2))
    assert figures["epochs"][-1]["train"] < 0.75  # one number per episode: hard to memorise
    assert figures["epochs"][-1]["held_out"] < 0.7


def test_what_cannot_be_probed_is_refused():
    with pytest.raises(ValueError, match="no agent"):
        readout.first_observations(readout.Args(agent="nobody", episodes=2))
    with pytest.raises(ValueError, match="rooms"):
        readout.first_observations(readout.Args(scenario="fruits_poisons", agent="agent_0"))
