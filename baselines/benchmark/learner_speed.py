"""How fast ``baselines.ppo`` learns, against the rate its parts allow, in one run.

Four figures, each in agent-steps per CPU-second (every thread of the process counted)
on the run's own scenario, worlds and network:

- env: the batched env alone, stepped with random actions (resets included);
- act: the acting pass alone (forward and sampling for every slot, with the copy of the
  observations into the rollout);
- update: PPO's epochs alone, over a rollout of real observations;
- env and act in turn: the two stepped one after the other, as a rollout steps them
  (random actions still). Each alone keeps its data in the core's caches from one call to
  the next; in turn, each finds the other's there: on a 2-core Xeon with 2 MiB of L2 per
  core, the batched env of 16 worlds ran at about 0.7x its rate alone, as it did with a
  sweep over 4 MB of memory between its steps instead of the acting pass;
- loop: ``baselines.ppo`` itself, from its first rollout to its last update (start-up
  excluded, as the run's JSON reports it), with collection and update in turn and, with
  ``--overlap``, at once.

The parts allow ``1 / (1/env + 1/act + 1/update)`` agent-steps per CPU-second; the
loop's efficiency is its rate against that. ``1 / (1/in turn + 1/update)`` is what they
allow stepped in turn: the loop's rate against that says what the loop adds beyond the
caches' share. Each part is timed in slices alternating with the others', so that a
machine whose speed drifts moves them alike; the machine's load average is printed
beside them, and a calibration (a fixed matrix product, timed in the same run) says how
fast the machine was.

    python -m baselines.benchmark.learner_speed --scenario fruits_poisons --num-envs 16
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import tyro
from torch.utils._pytree import tree_leaves

import flatland_ma  # noqa: F401, I001 - first, before torch (flatland_ma.sensors.threads)
from baselines import ppo
from baselines.benchmark.machine import calibration
from baselines.buffers import keep_freed_memory
from baselines.common import cpu_seconds, input_channels
from baselines.networks import Agent
from baselines.ppo_learner import Rollout


@dataclass
class Args:
    scenario: str = "fruits_poisons"
    """The scenario to measure on."""
    num_envs: int = 16
    """Worlds in the batched env (as ``baselines.ppo --num-envs``)."""
    num_steps: int = 128
    """Steps per slot in each rollout."""
    rollouts: int = 4
    """Rollouts' worth of steps for each part, in as many slices."""
    loop_timesteps: int = 65_536
    """Agent-steps of each ``baselines.ppo`` run."""
    torch_threads: int = 1
    """Threads torch may use."""
    overlap: bool = True
    """Also run the loop with collection and update overlapped."""
    json: str = ""
    """Also write the figures to this JSON file."""


class Parts:
    """The env, the acting pass and the update of one configuration, each timed alone."""

    def __init__(self, args: Args):
        self.args = args
        run = ppo.Args(scenario=args.scenario, num_envs=args.num_envs, num_steps=args.num_steps)
        self.run = run
        self.env = ppo.batched_env(run)
        self.observation, _ = self.env.reset(seed=0)
        env = self.env
        self.agent = Agent(
            env.single_observation_space,
            env.single_action_space,
            run.hidden,
            input_channels(run.use_depth),
            run.network,
        )
        self.optimizer = torch.optim.Adam(self.agent.parameters(), lr=run.learning_rate, eps=1e-5)
        self.rollout = Rollout(self.agent, env, self.observation, args.num_steps)
        self.observation = self.rollout.collect(
            self.agent, env, self.observation, run.reward_scale, lambda *a: None
        )
        env.single_action_space.seed(0)
        self.actions = [
            np.stack([env.single_action_space.sample() for _ in range(env.num_slots)])
            for _ in range(args.num_steps)
        ]
        self.seconds = {"env": 0.0, "act": 0.0, "update": 0.0, "in_turn": 0.0}
        self.steps = dict.fromkeys(self.seconds, 0)

    def time_env(self) -> None:
        start = cpu_seconds()
        for action in self.actions:
            self.env.step(action)
        self._add("env", start, len(self.actions) * self.env.num_slots)

    def _act(self, t: int) -> None:
        """The acting pass of step ``t``: the observation copied into the rollout, then
        the forward pass and sampling for every slot (no gradient)."""
        for into, x in zip(tree_leaves(self.rollout.observations), tree_leaves(self.observation)):
            into[t].copy_(torch.from_numpy(x))
        self.agent.act(self.rollout.views[t])

    def time_act(self) -> None:
        start = cpu_seconds()
        with torch.no_grad():
            for t in range(self.args.num_steps):
                self._act(t)
        self._add("act", start, self.args.num_steps * self.env.num_slots)

    def time_in_turn(self) -> None:
        """The env and the acting pass one after the other, each step."""
        start = cpu_seconds()
        with torch.no_grad():
            for t, action in enumerate(self.actions):
                self._act(t)
                self.observation = self.env.step(action)[0]
        self._add("in_turn", start, len(self.actions) * self.env.num_slots)

    def time_update(self) -> None:
        start = cpu_seconds()
        self.rollout.learn(self.agent, self.optimizer, self.run)
        self._add("update", start, int(self.rollout.acting.sum()))

    def _add(self, part: str, start: float, steps: int) -> None:
        self.seconds[part] += cpu_seconds() - start
        self.steps[part] += steps

    def rates(self) -> dict[str, float]:
        return {part: self.steps[part] / self.seconds[part] for part in self.seconds}


def loop(args: Args, overlap: bool) -> dict:
    """One ``baselines.ppo`` run of ``loop_timesteps``: its rates from its own JSON."""
    with tempfile.TemporaryDirectory() as folder:
        run = ppo.Args(
            scenario=args.scenario,
            num_envs=args.num_envs,
            num_steps=args.num_steps,
            total_timesteps=args.loop_timesteps,
            torch_threads=args.torch_threads,
            overlap=overlap,
            csv=str(Path(folder) / "seed_0.csv"),
            tensorboard=False,
            checkpoint_every=0,
        )
        summary = ppo.main(run)
    return {
        "agent_steps": summary["steps"],
        "per_cpu_second": summary["steps"] / summary["cpu_seconds"],
        "per_wall_second": summary["steps"] / summary["wall_seconds"],
        "cpu_seconds": summary["cpu_seconds"],
        "wall_seconds": summary["wall_seconds"],
        "threads": summary["threads"],
        "policy_lag": summary["policy_lag"],
    }


def measure(args: Args) -> dict:
    torch.set_num_threads(args.torch_threads)
    keep_freed_memory()
    load = os.getloadavg()
    parts = Parts(args)
    timers = (parts.time_env, parts.time_act, parts.time_update, parts.time_in_turn)
    for time_part in timers:  # warm: first calls allocate
        time_part()
    parts.seconds, parts.steps = dict.fromkeys(parts.seconds, 0.0), dict.fromkeys(parts.steps, 0)
    for _ in range(args.rollouts):  # slices, alternating, so drift moves all alike
        for time_part in timers:
            time_part()
    rates = parts.rates()
    allowed = 1.0 / sum(1.0 / rates[part] for part in ("env", "act", "update"))
    in_turn = 1.0 / (1.0 / rates["in_turn"] + 1.0 / rates["update"])
    parts.env.close()
    loops = {"serial": loop(args, overlap=False)}
    if args.overlap:
        loops["overlapped"] = loop(args, overlap=True)
    for figures in loops.values():
        figures["efficiency"] = figures["per_cpu_second"] / allowed
        figures["efficiency_in_turn"] = figures["per_cpu_second"] / in_turn
    return {
        "scenario": args.scenario,
        "num_envs": args.num_envs,
        "slots": parts.env.num_slots,
        "parts_per_cpu_second": rates,
        "allowed_per_cpu_second": allowed,
        "allowed_in_turn_per_cpu_second": in_turn,
        "loops": loops,
        "calibration_matmuls_per_second": calibration(),
        "load_average": [round(x, 2) for x in load],
        "load_average_end": [round(x, 2) for x in os.getloadavg()],
        "cpus": len(os.sched_getaffinity(0)),
    }


def report(figures: dict) -> str:
    rates = figures["parts_per_cpu_second"]
    lines = [
        f"{figures['scenario']} x{figures['num_envs']} ({figures['slots']} slots), "
        f"agent-steps per CPU-second; load {figures['load_average']} -> "
        f"{figures['load_average_end']}, calibration "
        f"{figures['calibration_matmuls_per_second']:.0f} matmuls/s",
        f"  env alone      {rates['env']:>9,.0f}",
        f"  act alone      {rates['act']:>9,.0f}",
        f"  update alone   {rates['update']:>9,.0f}",
        f"  parts allow    {figures['allowed_per_cpu_second']:>9,.0f}",
        f"  env, act in turn {rates['in_turn']:>7,.0f}  (caches shared: "
        f"{rates['in_turn'] / (1 / (1 / rates['env'] + 1 / rates['act'])):.0%} of the two alone)",
        f"  in turn allow  {figures['allowed_in_turn_per_cpu_second']:>9,.0f}",
    ]
    for name, loop_figures in figures["loops"].items():
        lines.append(
            f"  loop, {name:<10}{loop_figures['per_cpu_second']:>9,.0f}  "
            f"({loop_figures['efficiency']:.0%} of the parts, "
            f"{loop_figures['efficiency_in_turn']:.0%} of them in turn; "
            f"{loop_figures['per_wall_second']:,.0f} per wall-second, "
            f"policy lag {loop_figures['policy_lag']})"
        )
    return "\n".join(lines)


def main(args: Args) -> dict:
    figures = measure(args)
    print(report(figures), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    return figures


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
