"""Where a task's reward lies within an episode: the first question for a task a learner
does not solve (is the reward reachable by exploring within one episode, and is the episode
long enough?), answered for every shipped scenario by play, not by training.

For each scenario, random play and the scenario's scripted reference solver each play the
benchmark's held-out episodes (``settings.yaml``: ``episodes`` from ``eval_seed``). For each
episode: the step at which a scored agent was first paid (a positive reward), or none. The
table gives, per method, the share of episodes with a payment, the median step of the first
one, and that step as a share of the episode's step limit.

A task where random play is never paid in an episode gives an on-policy learner nothing to
learn from until its policy finds the reward by chance: exploration, not the budget, is
then what blocks it. One where even the solver's first payment comes late in the episode
leaves a learner few chances per episode.

    python -m baselines.benchmark.reach                  # every scenario -> results/reach.json
    python -m baselines.benchmark.reach --only maze_goal switch_door
    python -m baselines.benchmark.reach --table          # the Markdown table of the JSON
"""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from baselines.benchmark.play import policy_names, scenario_seeds, scored_agents
from baselines.benchmark.records import OUT
from baselines.benchmark.settings import SETTINGS, load_config
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.policies.named import make_policy

REACH = OUT.parent / "reach.json"
METHODS = ("random", "scripted")


@dataclass
class Reach:
    """One method's episodes on one scenario."""

    episodes: int
    paid: int
    """Episodes in which a scored agent was paid at least once."""
    first_steps: list[int | None]
    """Each episode's step (from 1) of the first payment, None where there was none."""
    lengths: list[int]
    """Each episode's length in steps."""
    scores: list[float]
    limit: int
    """The episode's step limit."""

    @property
    def median_first(self) -> float | None:
        steps = [s for s in self.first_steps if s is not None]
        return float(np.median(steps)) if steps else None

    @property
    def median_share(self) -> float | None:
        """The median first payment's step over the step limit."""
        first = self.median_first
        return None if first is None else first / self.limit


def first_payment(
    env: FlatlandParallelEnv, policies: dict, seed: int
) -> tuple[int | None, int, float]:
    """One episode from ``reset(seed=seed)``: (the step of the first positive reward of a
    scored agent, or None; the episode's length; the scored agents' mean return)."""
    scored = scored_agents(env)
    observations, _ = env.reset(seed=seed)
    for policy in policies.values():
        if hasattr(policy, "reset"):
            policy.reset()
    first, steps = None, 0
    totals = dict.fromkeys(env.possible_agents, 0.0)
    while env.agents:
        actions = {a: policies[a].act(observations[a]) for a in env.agents}
        observations, rewards, _, _, _ = env.step(actions)
        steps += 1
        for a, r in rewards.items():
            totals[a] += r
            if first is None and r > 0 and a in scored:
                first = steps
    return first, steps, float(np.mean([totals[a] for a in scored]))


def reach(name: str, method: str, seeds: list[int], seed: int = 0) -> Reach:
    """``method``'s play of scenario ``name`` on ``seeds`` (policies seeded from ``seed``)."""
    env = FlatlandParallelEnv(name)
    try:
        names = policy_names(env, method)
        agents = env.possible_agents
        policies = {
            a: make_policy(names[a], env, a, seed=seed * 1000 + agents.index(a)) for a in agents
        }
        played = [first_payment(env, policies, s) for s in seeds]
        limit = env.step_limit or max(p[1] for p in played)
    finally:
        env.close()
    firsts = [p[0] for p in played]
    return Reach(
        len(seeds),
        sum(f is not None for f in firsts),
        firsts,
        [p[1] for p in played],
        [p[2] for p in played],
        int(limit),
    )


def table(results: dict[str, dict[str, dict]]) -> str:
    """The Markdown table of ``results`` (scenario -> method -> ``Reach`` as a dict)."""
    lines = [
        "| scenario | step limit | random: paid in | random: first paid at | "
        "scripted: paid in | scripted: first paid at |",
        "|---|---|---|---|---|---|",
    ]
    for name in sorted(results):
        row = [f"`{name}`"]
        row.append(str(results[name][METHODS[0]]["limit"]))
        for method in METHODS:
            r = Reach(**results[name][method])
            row.append(f"{r.paid} of {r.episodes}")
            first = r.median_first
            share = r.median_share
            row.append("-" if first is None else f"step {first:.0f} ({share:.0%} of it)")
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    import flatland_ma

    parser = argparse.ArgumentParser(prog="python -m baselines.benchmark.reach")
    parser.add_argument("--only", nargs="+", default=None, help="these scenarios only")
    parser.add_argument("--out", default=str(REACH))
    parser.add_argument("--table", action="store_true", help="print the table of --out")
    args = parser.parse_args(argv)
    out = Path(args.out)
    if args.table:
        print(table(json.loads(out.read_text())))
        return
    names = flatland_ma.list_scenarios()
    if args.only:
        unknown = sorted(set(args.only) - set(names))
        if unknown:
            parser.error(f"no shipped scenario {', '.join(unknown)}")
        names = [n for n in names if n in args.only]
    results = json.loads(out.read_text()) if out.exists() else {}
    seeds = scenario_seeds(load_config(SETTINGS))
    for name in names:
        results[name] = {m: asdict(reach(name, m, seeds)) for m in METHODS}
        print(name, {m: (r["paid"], r["episodes"]) for m, r in results[name].items()}, flush=True)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")
    print(table(results))


if __name__ == "__main__":
    main()
