"""Every shipped scenario replays its recorded trajectories (``tests/trajectories.py``)
bit for bit: through one parallel env, through the batched env (each world's slots
against that world's recording) and through the sharded env (two processes), across
resets. The observations and the bodies' poses and velocities are held to their hashes,
rewards to their exact float64 values, and every agent's ending to its status."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import flatland_ma
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import BatchedParallelEnv
from tests.trajectories import (
    DATA,
    MAX_CYCLES,
    SEED,
    STATUS,
    bodies_hash,
    load,
    observations_hash,
)

SCENARIOS = flatland_ma.list_scenarios()
ENDS = {code: ends for ends, code in STATUS.items()}
"""A status character -> (terminated, truncated)."""


def test_every_shipped_scenario_has_its_recording():
    assert sorted(p.stem for p in DATA.glob("*.json")) == sorted(SCENARIOS)


def _exact(got: list[float], want: list[float]) -> bool:
    """Equal to the bit (0.0 and -0.0 differ)."""
    return [float(g).hex() for g in got] == [float(w).hex() for w in want]


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_one_parallel_env_replays_the_recording(scenario):
    recording = load(scenario)
    agents = recording["agents"]
    m = len(agents)
    env = flatland_ma.parallel_env(scenario, max_cycles=recording["max_cycles"])
    assert env.possible_agents == agents
    for world in recording["worlds"]:
        for t, kind in enumerate(world["kind"]):
            where = (world["seed"], t)
            status = world["status"][t * m : (t + 1) * m]
            if kind == "R":
                assert t == 0 or not env.agents, where
                observations, _ = env.reset(seed=world["seed"]) if t == 0 else env.reset()
                live = [a for a in agents if a in env.agents]
            else:
                live = [a for a in agents if a in env.agents]
                actions = dict(zip(agents, world["actions"][t], strict=True))
                observations, rew, term, trunc, _ = env.step({a: actions[a] for a in live})
                assert _exact([rew[a] for a in live], world["rewards"][t]), where
                ends = {a: (term[a], trunc[a]) for a in live}
                assert all(type(v) is bool for e in ends.values() for v in e), where
                assert [ends.get(a) for a in agents] == [ENDS.get(c) for c in status], where
            assert [a in live for a in agents] == [c != "." for c in status], where
            assert observations_hash(live, observations) == world["obs"][t], where
            assert bodies_hash(env) == world["bodies"][t], where
    env.close()


def _slot_observation(batch: Any, observations: Any, slot: int, own_space: Any) -> Any:
    """Slot ``slot``'s observation as its agent's own space has it (the leading corner of
    each padded entry, when the batch pads)."""
    if batch.padding is None:
        if isinstance(observations, dict):
            return {k: v[slot] for k, v in observations.items()}
        return observations[slot]
    own = own_space.spaces if hasattr(own_space, "spaces") else {"observation": own_space}
    entries = {
        k: observations[k][slot][tuple(slice(0, n) for n in box.shape)].astype(box.dtype)
        for k, box in own.items()
    }
    return entries if hasattr(own_space, "spaces") else entries["observation"]


def _replay_batch(batch: Any, recording: dict, own_spaces: list, bodies: bool) -> None:
    """Drive ``batch`` (one world per recorded world, seeded as recorded) with the
    recorded actions, and hold each world's slots to its recording at every step."""
    agents, worlds = recording["agents"], recording["worlds"]
    m = len(agents)
    assert [w["seed"] for w in worlds] == [SEED + w for w in range(len(worlds))]
    observations, infos = batch.reset(seed=SEED)
    for t in range(len(worlds[0]["kind"])):
        if t > 0:
            actions = [a for world in worlds for a in world["actions"][t]]
            observations, rewards, terminations, truncations, infos = batch.step(
                np.asarray(actions)
            )
        for w, world in enumerate(worlds):
            where = (world["seed"], t)
            status = world["status"][t * m : (t + 1) * m]
            slots = range(w * m, (w + 1) * m)
            active = [bool(infos["active"][s]) for s in slots]
            assert active == [c != "." for c in status], where
            live = [a for a, on in zip(agents, active, strict=True) if on]
            got = {
                a: _slot_observation(batch, observations, s, own_spaces[j])
                for j, (a, s) in enumerate(zip(agents, slots, strict=True))
                if active[j]
            }
            assert observations_hash(live, got) == world["obs"][t], where
            if bodies:
                assert bodies_hash(batch.worlds[w]) == world["bodies"][t], where
            if t == 0:
                continue
            played = [float(rewards[s]) for s, on in zip(slots, active, strict=True) if on]
            want = world["rewards"][t] if world["kind"][t] == "S" else [0.0] * len(live)
            assert _exact(played, want), where
            assert not any(rewards[s] for s, on in zip(slots, active, strict=True) if not on)
            ends = [(bool(terminations[s]), bool(truncations[s])) for s in slots]
            assert ends == [ENDS.get(c, (False, False)) for c in status], where


def _own_spaces(scenario: str) -> list:
    env = flatland_ma.parallel_env(scenario)
    spaces = [env.observation_space(a) for a in env.possible_agents]
    env.close()
    return spaces


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_a_batch_replays_each_worlds_recording_in_its_slots(scenario):
    recording = load(scenario)
    n = len(recording["worlds"])
    batch = BatchedParallelEnv(scenario, num_worlds=n, max_cycles=MAX_CYCLES, pad=True)
    _replay_batch(batch, recording, _own_spaces(scenario), bodies=True)
    batch.close()


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_two_shards_replay_each_worlds_recording_in_its_slots(scenario):
    recording = load(scenario)
    n = len(recording["worlds"])
    sharded = ShardedParallelEnv(scenario, n, shards=2, max_cycles=MAX_CYCLES, pad=True)
    try:
        _replay_batch(sharded, recording, _own_spaces(scenario), bodies=False)
    finally:
        sharded.close()
