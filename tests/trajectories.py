"""Recorded trajectories: every shipped scenario played for fixed seeds and fixed actions,
kept in ``tests/data/trajectories/<scenario>.json`` so that a change of the core is held
to the numbers the code gave when they were recorded (``RECORDED_FROM``).

A recording is ``WORLDS`` worlds of ``STEPS`` steps each, with episodes cut at
``MAX_CYCLES`` so that every world goes through resets. World ``w`` is reset with seed
``SEED + w`` (as a batched env reset with ``SEED`` seeds it) and, each time its episode
ends, reset again without a seed at the next step: the batched envs' ``NEXT_STEP``
autoreset, so one recording serves the single env, the batched env and the sharded env.
The first ``SOLVED`` worlds are played by the scenario's reference solver, the others by
actions from ``numpy.random.default_rng(ACTION_SEED + w)``; either way the actions are
kept in the recording (one per possible agent every step, also for a reset or an agent
that has left, where the env does not use it), and replayed as they are.

Each step is kept compactly, one entry per step in each column: ``kind``, whether it was
a reset (``R``) or a step (``S``); ``status``, one character per possible agent
(``STATUS``); ``actions``; ``rewards``, exact float64 (JSON keeps a float's exact value),
one per agent that played; ``obs``, a hash of the observations returned (agent by agent
in the possible agents' order); ``bodies``, a hash of every body's pose and velocity.

A recording names the scenario's ``version``: a change that alters a recording is a
change of the task, which bumps its version. Record again (only then):
``PYTHONPATH=. python -m tests.trajectories``.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

import flatland_ma
from flatland_ma.policies.named import make_policy
from flatland_ma.policies.scores_header import solver_names

DATA = Path(__file__).parent / "data" / "trajectories"
RECORDED_FROM = "e33516d"
"""The commit of main whose code gave the recordings."""
WORLDS, SOLVED, STEPS, MAX_CYCLES = 3, 2, 100, 80
"""Three worlds of 100 steps of episodes of at most 80 steps: every world resets at least
once; the first two play the scenario's reference solver (which ends many scenarios'
episodes within 80 steps), the third random actions."""
SEED, ACTION_SEED = 7, 1000
HASH_CHARS = 12
"""The leading hex digits of a sha256 kept (48 bits)."""


def draw(space: spaces.Space, rng: np.random.Generator) -> Any:
    """One action of ``space`` from ``rng`` (numpy's generators give the same numbers on
    every platform and version, unlike a space's own ``sample``)."""
    if isinstance(space, spaces.Discrete):
        return int(space.start + rng.integers(space.n))
    if isinstance(space, spaces.MultiDiscrete):
        return (space.start + rng.integers(space.nvec)).astype(space.dtype)
    if isinstance(space, spaces.Box):
        return rng.uniform(space.low, space.high).astype(space.dtype)
    if isinstance(space, spaces.Dict):
        return {key: draw(space[key], rng) for key in sorted(space.spaces)}
    raise TypeError(f"no fixed draw for actions of {space}")


def observation_bytes(observation: Any) -> bytes:
    """An observation's bytes: a ``Box``'s in C order, a ``Dict``'s entry by entry in
    sorted order with each entry's name."""
    if isinstance(observation, dict):
        return b"".join(k.encode() + observation_bytes(observation[k]) for k in sorted(observation))
    return np.asarray(observation).tobytes()


def short_hash(*chunks: bytes) -> str:
    digest = hashlib.sha256()
    for chunk in chunks:
        digest.update(chunk)
    return digest.hexdigest()[:HASH_CHARS]


def observations_hash(agents: list[str], observations: dict[str, Any]) -> str:
    """The hash of ``agents``' observations, in that order, each with its name."""
    return short_hash(*(a.encode() + observation_bytes(observations[a]) for a in agents))


def bodies_hash(env: Any) -> str:
    """The hash of every entity's body (and its parts' bodies) of a parallel env's world:
    position, angle, velocity and angular velocity, exactly."""
    values = []
    for entity in env.episode.world.entities:
        for body in (entity.body, *entity.aux_bodies):
            values += [*body.position, body.angle, *body.velocity, body.angular_velocity]
    return short_hash(np.array(values, np.float64).tobytes())


STATUS = {(False, False): "o", (True, False): "T", (False, True): "U", (True, True): "B"}
"""An agent's status after a step it played in: on, terminated, truncated, or both; an
agent that did not play (it had left) is ".". A reset's status is "o" for every agent it
returned."""


def _policies(env: Any, world: int) -> dict[str, Any]:
    """The scenario's reference solver for the first ``SOLVED`` worlds (their episodes
    end early, agents leave, rewards come), else none (the world plays random actions)."""
    if world >= SOLVED:
        return {}
    names = solver_names(env)
    return {a: make_policy(names[a], env, a, i) for i, a in enumerate(env.possible_agents)}


def _plain(action: Any) -> Any:
    return action.tolist() if isinstance(action, np.ndarray) else int(action)


def record_world(scenario: str, world: int) -> dict[str, Any]:
    """World ``world`` of ``scenario``'s recording, played by one parallel env."""
    env = flatland_ma.parallel_env(scenario, max_cycles=MAX_CYCLES)
    agents = env.possible_agents
    policies = _policies(env, world)
    rng = np.random.default_rng(ACTION_SEED + world)
    columns = ("kind", "status", "actions", "rewards", "obs", "bodies")
    steps: dict[str, list] = {k: [] for k in columns}

    def keep(kind, actions, live, observations, rewards=None, terminated=None, truncated=None):
        steps["kind"].append(kind)
        if rewards is None:
            rewards, status = [], ["o" if a in live else "." for a in agents]
        else:
            ends = {a: STATUS[bool(terminated[a]), bool(truncated[a])] for a in live}
            status = [ends.get(a, ".") for a in agents]
            rewards = [float(rewards[a]) for a in live]
        steps["status"].append("".join(status))
        steps["actions"].append([_plain(actions[a]) for a in agents])
        steps["rewards"].append(rewards)
        steps["obs"].append(observations_hash(live, observations))
        steps["bodies"].append(bodies_hash(env))

    def reset(**seed):
        observations, _ = env.reset(**seed)
        for policy in policies.values():
            getattr(policy, "reset", lambda: None)()
        return observations

    observations = reset(seed=SEED + world)
    keep("R", {a: 0 for a in agents}, [a for a in agents if a in env.agents], observations)
    for _ in range(STEPS):
        actions = {a: draw(env.action_space(a), rng) for a in agents}
        if not env.agents:
            observations = reset()
            keep("R", actions, [a for a in agents if a in env.agents], observations)
            continue
        live = [a for a in agents if a in env.agents]
        for a in live:
            if a in policies:
                actions[a] = policies[a].act(observations[a])
        observations, rew, term, trunc, _ = env.step({a: actions[a] for a in live})
        keep("S", actions, live, observations, rew, term, trunc)
    env.close()
    steps["kind"] = "".join(steps["kind"])
    steps["status"] = "".join(steps["status"])
    return {"seed": SEED + world, **steps}


def record(scenario: str) -> dict[str, Any]:
    env = flatland_ma.parallel_env(scenario)
    agents, version = list(env.possible_agents), env.spec.version
    env.close()
    return {
        "scenario": scenario,
        "version": version,
        "recorded_from": RECORDED_FROM,
        "max_cycles": MAX_CYCLES,
        "agents": agents,
        "worlds": [record_world(scenario, w) for w in range(WORLDS)],
    }


def path_of(scenario: str) -> Path:
    return DATA / f"{scenario}.json"


def load(scenario: str) -> dict[str, Any]:
    return json.loads(path_of(scenario).read_text())


def dump(recording: dict[str, Any]) -> str:
    """The recording as JSON with one line per column of a world (small, and diffable)."""
    head = json.dumps({k: v for k, v in recording.items() if k != "worlds"})
    worlds = []
    for world in recording["worlds"]:
        columns = [f'  "{k}": {json.dumps(v, separators=(",", ":"))}' for k, v in world.items()]
        worlds.append(" {\n" + ",\n".join(columns) + "\n }")
    return head[:-1] + ', "worlds": [\n' + ",\n".join(worlds) + "\n]}\n"


ENDS = {code: ends for ends, code in STATUS.items()}
"""A status character -> (terminated, truncated)."""


def _exact(got: list[float], want: list[float]) -> bool:
    """Equal to the bit (0.0 and -0.0 differ)."""
    return [float(g).hex() for g in got] == [float(w).hex() for w in want]


def replay_single(scenario: str) -> None:
    """Play ``scenario``'s recording through one parallel env, every world in turn,
    asserting each step's numbers."""
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


def replay_batch(batch: Any, recording: dict, own_spaces: list, bodies: bool) -> None:
    """Drive ``batch`` (a batched or sharded env of one world per recorded world, reset
    with ``SEED``) with the recorded actions, and hold each world's slots to its
    recording at every step (``bodies``: the bodies' hash too, where the worlds are in
    this process; ``own_spaces``: each agent's observation space, to unpad)."""
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


def own_spaces(scenario: str) -> list:
    """Each agent's own observation space."""
    env = flatland_ma.parallel_env(scenario)
    spaces = [env.observation_space(a) for a in env.possible_agents]
    env.close()
    return spaces


def main() -> None:
    DATA.mkdir(parents=True, exist_ok=True)
    for scenario in flatland_ma.list_scenarios():
        recording = record(scenario)
        path_of(scenario).write_text(dump(recording))
        assert json.loads(path_of(scenario).read_text()) == recording
        print(scenario, path_of(scenario).stat().st_size, "bytes")


if __name__ == "__main__":
    main()
