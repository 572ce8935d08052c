"""Can PPO's network, seeing only what an agent sees, play as well as the task's scripted
solver? An imitation probe (DAgger).

The scripted solvers read the world (where the goal is, the maze's plan, the other
agents); the learner reads its own observations. This probe asks whether those are enough
for ``baselines.ppo``'s own network, feed-forward (or recurrent, ``--memory gru``), apart
from reinforcement learning's exploration and credit: it is taught the solver's action at
every step by cross-entropy, first on episodes the solver plays, then, round by round, on
episodes the network itself plays with the solver's actions as the labels (Ross et al.,
"A Reduction of Imitation Learning and Structured Prediction to No-Regret Online
Learning", 2011), every round's steps kept. Agents the benchmark does not score play at
random, as there. The final network is saved as a checkpoint and scored on the
benchmark's held-out episodes, normalised by the committed random and scripted scores.

An imitator near the solver's score says the task is within the network's reach from
what the agent sees, and a PPO run that stays below it fails at finding or crediting the
reward; an imitator far below says a policy that reads one observation cannot do what the
solver does (it needs memory, or sees too little).

    python -m baselines.benchmark.imitate --scenario scent_rooms
    python -m baselines.benchmark.imitate --scenario scent_rooms --record   # results/imitation.json

``--record`` keeps the run's figures, CPU time, the machine's load and calibration and the
commit in ``results/imitation.json`` under the scenario's name (the benchmark page's
section "Within reach of what the agent sees" is made from it).
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np
import torch
import tyro
from torch.utils._pytree import tree_map

from baselines.benchmark.imitate_rounds import (
    Kept,
    collect_sequences,
    step_worlds,
    train,
    train_sequences,
)
from baselines.benchmark.levels import held_out
from baselines.benchmark.machine import calibrate, commit, cpu_seconds, versions
from baselines.benchmark.play import scored_agents
from baselines.benchmark.settings import SETTINGS, load_config
from baselines.benchmark.within_reach import IMITATION
from baselines.common import input_channels
from baselines.networks import Agent
from flatland_ma.envs.padding import Padding
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.policies.checkpoint import SUFFIX, write_checkpoint
from flatland_ma.policies.named import make_policy
from flatland_ma.policies.scores_header import solver_names

TRAINING_SEED = 5_000_000
"""Episodes are reset from seeds here on (the benchmark holds out 100,000 on)."""


@dataclass
class Args:
    scenario: str = "scent_rooms"
    """The scenario (a shipped name: it is scored on the benchmark's held-out episodes)."""
    worlds: int = 8
    """Worlds played side by side."""
    rounds: int = 5
    """Rounds the network plays (after the first, which the solver plays)."""
    steps: int = 16384
    """Steps each round collects (every imitating agent's step counts)."""
    epochs: int = 4
    """Passes over every step kept so far, after each round."""
    batch: int = 256
    learning_rate: float = 3e-4
    ppo_steps: int = 0
    """Then train ``baselines.ppo`` from the imitator for this many agent-steps, in the
    task's standard configuration with its curriculum left out, and score it too (0: no
    PPO). The imitator's network takes that configuration's ``hidden``, ``network`` and
    ``use_depth`` either way, so that PPO can start from it."""
    ppo_anchor: float = 0.0
    """With ``ppo_steps``: ``baselines.ppo``'s ``--anchor``, a pull towards the imitator's
    policy (``baselines.anchor``), which PPO's updates otherwise undo; 0: none."""
    memory: Literal["none", "gru"] = "none"
    """The network's recurrent core, as ``baselines.ppo``'s ``--memory``: "gru" plays and
    learns slot by slot from sequences (``imitate_rounds``); PPO from it has it too."""
    sequence: int = 64
    """With memory: steps of each piece of a sequence a minibatch replays."""
    seed: int = 0
    checkpoint: str = ""
    """Where the network goes (default runs/imitate/<scenario>/seed_<seed>.safetensors)."""
    json: str = ""
    """Also write the figures to this JSON file."""
    record: bool = False
    """Keep the figures in results/imitation.json, under the scenario's name."""
    teacher: str = ""
    """A shipped policy to imitate instead of the scenario's solver (e.g. "wall_follower",
    which reads only the agent's camera); not with ``record``, which keeps the solver's."""


class Worlds:
    """``Args.worlds`` parallel envs of the scenario, each agent's solver and the agents
    that imitate it (the scored ones); observations as the network reads them."""

    def __init__(self, args: Args):
        self.envs = [FlatlandParallelEnv(args.scenario) for _ in range(args.worlds)]
        first = self.envs[0]
        self.agents = list(first.possible_agents)
        self.imitating = [a for a in self.agents if a in scored_agents(first)]
        spaces_ = {str(first.action_space(a)) for a in self.imitating}
        if len(spaces_) != 1:
            raise ValueError(f"{args.scenario}: the imitating agents act in {spaces_}")
        names = (  # ValueError if the scenario names no solver
            {a: args.teacher for a in self.imitating} if args.teacher else solver_names(first)
        )
        self.padding = Padding.of(first)
        self.space = self.padding.space if self.padding else first.observation_space(self.agents[0])
        self.action_space = first.action_space(self.imitating[0])
        others = [a for a in self.agents if a not in self.imitating]
        self.experts = [
            {a: make_policy(names[a], env, a, args.seed * 1000 + w) for a in self.imitating}
            for w, env in enumerate(self.envs)
        ]
        """Each world's solver of each imitating agent."""
        self.random = [
            {a: make_policy("random", env, a, args.seed * 1000 + w) for a in others}
            for w, env in enumerate(self.envs)
        ]
        """Each world's random play of each agent the benchmark does not score."""
        self.episodes = 0

    def view(self, agent: str, observation):
        """An agent's observation as the network reads it (padded if roles differ)."""
        if self.padding is None:
            return observation
        return self.padding.pad(self.agents.index(agent), observation)

    def reset(self, w: int, base: int):
        for policy in self.experts[w].values():
            getattr(policy, "reset", lambda: None)()
        observations, _ = self.envs[w].reset(seed=base + self.episodes)
        self.episodes += 1
        return observations

    def close(self) -> None:
        for env in self.envs:
            env.close()


def sample(network: Agent, views: list) -> np.ndarray:
    """One action per row, drawn from the network's policy."""
    batch = tree_map(lambda *xs: torch.from_numpy(np.stack(xs)), *views)
    with torch.inference_mode():
        action, *_ = network.act(batch)
    return action.numpy()


def collect(worlds: Worlds, network: Agent | None, steps: int, base: int) -> dict:
    """Play until ``steps`` imitating steps are kept, the network driving the imitating
    agents (the solver if ``network`` is None); each kept step's view and the solver's
    action, the returns of the episodes that ended within the round (episodes that end
    early, as a goal found does, are over-represented among them: the held-out score is
    the measure) and how often the network's actions were the solver's."""
    views, labels, returns, agreed = [], [], [], []
    observations = [worlds.reset(w, base) for w in range(len(worlds.envs))]
    totals = [dict.fromkeys(worlds.agents, 0.0) for _ in worlds.envs]
    while len(labels) < steps:
        keys, step_views, step_labels = [], [], []
        actions: list[dict] = []
        for w, env in enumerate(worlds.envs):
            acts = {}
            for a in env.agents:
                if a in worlds.imitating:
                    expert = worlds.experts[w][a].act(observations[w][a])
                    keys.append((w, a))
                    step_views.append(worlds.view(a, observations[w][a]))
                    step_labels.append(np.atleast_1d(np.asarray(expert, np.int64)))
                    acts[a] = expert
                else:
                    acts[a] = worlds.random[w][a].act(observations[w][a])
            actions.append(acts)
        if network is not None and keys:
            drawn = sample(network, step_views)
            for (w, a), row, label in zip(keys, drawn, step_labels):
                agreed.append(bool(np.array_equal(row, label)))
                actions[w][a] = row if np.ndim(actions[w][a]) else int(row[0])
        views += step_views
        labels += step_labels
        step_worlds(worlds, observations, actions, totals, returns, base)
    return {
        "views": views,
        "labels": labels,
        "returns": returns,
        "agreement": float(np.mean(agreed)) if agreed else None,
    }


def standard_args(args: Args, log: Path = Path("-"), start: Path | None = None):
    """``baselines.ppo``'s arguments for the task's standard configuration, without its
    curriculum, logged at ``log``, from the checkpoint ``start``, for ``args.ppo_steps``."""
    from baselines.benchmark.train import ppo_args

    task = load_config(SETTINGS).task(args.scenario, "standard")
    ppo = ppo_args(args.scenario, args.seed, task, log)
    return replace(
        ppo,
        curriculum="",
        total_timesteps=args.ppo_steps,
        resume=False,
        checkpoint_every=0,
        init_from="" if start is None else str(start),
        memory=args.memory,
        anchor=args.ppo_anchor,
    )


def then_ppo(args: Args, imitator: Path) -> dict:
    """PPO from the imitator (``standard_args``): its run's figures and held-out score."""
    from baselines import ppo

    log = imitator.with_name(f"{imitator.stem}_then_ppo.csv")  # one PPO run an imitator
    run = standard_args(args, log, imitator)
    summary = ppo.main(run)
    return {
        "agent_steps": int(summary["steps"]),
        "cpu_seconds": round(float(summary["cpu_seconds"]), 1),
        "options": {k: v for k, v in asdict(run).items() if k not in ("csv", "init_from")},
        **held_out(args.scenario, args.seed, log.with_suffix(SUFFIX)),
    }


def teach(args: Args, worlds: Worlds, network: Agent) -> list[dict]:
    """The rounds: the solver's, then ``args.rounds`` of the network's, each followed by
    training on every step kept so far; each round's figures."""
    rng = np.random.default_rng(args.seed)
    optimizer = torch.optim.Adam(network.parameters(), lr=args.learning_rate)
    # a round keeps at most a step of every agent of every world beyond ``steps``
    kept = Kept((args.rounds + 1) * (args.steps + len(worlds.envs) * len(worlds.agents)))
    sequences: list = []  # with memory: every round's steps, slot by slot
    rounds = []
    for k in range(args.rounds + 1):
        base = TRAINING_SEED + args.seed * 100_000
        driver = network if k else None
        if network.core is not None:
            got = collect_sequences(worlds, driver, args.steps, base, args.sequence)
            sequences.append(got.pop("sequence"))
            loss = train_sequences(network, optimizer, sequences, args, rng)
            count = int(sum(seq.used.sum() for seq in sequences))
        else:
            got = collect(worlds, driver, args.steps, base)
            kept.add(got.pop("views"), got["labels"])
            loss = train(network, optimizer, *kept.arrays(), args, rng)
            count = kept.count
        driven = np.mean(got["returns"]) if got["returns"] else None
        rounds.append(
            {
                "round": k,
                "driver": "network" if k else "solver",
                "episodes": len(got["returns"]),
                "return": None if driven is None else round(float(driven), 6),
                "agreement": got["agreement"],
                "steps_kept": count,
                "loss": loss,
            }
        )
        print(_round_text(rounds[-1]), flush=True)
    return rounds


def imitate(args: Args) -> dict:
    """Every round, then the final network's held-out score (and PPO's from it)."""
    torch.manual_seed(args.seed)
    worlds = Worlds(args)
    shape = standard_args(args)
    network = Agent(
        worlds.space,
        worlds.action_space,
        shape.hidden,
        input_channels(shape.use_depth),
        shape.network,
        memory=args.memory,
    )
    try:
        rounds = teach(args, worlds, network)
    finally:
        worlds.close()
    path = Path(args.checkpoint or f"runs/imitate/{args.scenario}/seed_{args.seed}{SUFFIX}")
    write_checkpoint(
        path,
        network,
        scenario=args.scenario,
        observation_space=worlds.space,
        action_space=worlds.action_space,
        extra={
            "algorithm": "imitation",
            "overrides": {},
            "padded": worlds.padding is not None,
            "args": asdict(args),
        },
    )
    figures = {
        "scenario": args.scenario,
        "version": worlds.envs[0].spec.version,
        "args": asdict(args),
        "network": {
            "hidden": shape.hidden,
            "network": shape.network,
            "use_depth": shape.use_depth,
            "memory": args.memory,
        },
        "rounds": rounds,
        "checkpoint": str(path),
        **held_out(args.scenario, args.seed, path),
    }
    if args.ppo_steps:
        figures["then_ppo"] = then_ppo(args, path)
    return figures


def _round_text(row: dict) -> str:
    driven = "-" if row["return"] is None else f"{row['return']:.2f}"
    agreement = "-" if row["agreement"] is None else f"{row['agreement']:.2f}"
    return (
        f"  round {row['round']} ({row['driver']} plays): {row['episodes']} episodes, "
        f"return {driven}, the network's actions the solver's {agreement}; "
        f"{row['steps_kept']:,} steps kept, loss {row['loss']:.3f}"
    )


def record(figures: dict, path: Path = IMITATION) -> None:
    """Keep ``figures`` in ``path`` under the scenario's name (other scenarios' kept)."""
    kept = json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}
    kept[figures["scenario"]] = figures
    path.write_text(json.dumps(dict(sorted(kept.items())), indent=1) + "\n", encoding="utf-8")


def main(args: Args) -> dict:
    if args.record and args.teacher:
        raise ValueError("--record keeps the scenario's solver's probe: leave out --teacher")
    load, cpu, wall, speed = os.getloadavg()[0], cpu_seconds(), time.perf_counter(), calibrate()
    figures = imitate(args)
    figures.update(
        cpu_seconds=round(cpu_seconds() - cpu, 1),
        wall_seconds=round(time.perf_counter() - wall, 1),
        load_1min=[round(load, 2), round(os.getloadavg()[0], 2)],
        calibration=speed,
        commit=commit(),
        versions=versions(),
    )
    print(
        f"{args.scenario}: the imitator on the held-out episodes {figures['held_out']:.2f} "
        f"(normalised {figures['normalised']:.3f})"
    )
    if "then_ppo" in figures:
        then = figures["then_ppo"]
        print(
            f"  PPO from it, {then['agent_steps']:,} agent-steps: {then['held_out']:.2f} "
            f"(normalised {then['normalised']:.3f})"
        )
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    if args.record:
        record(figures)
    return figures


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
