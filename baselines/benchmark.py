"""The benchmark: random play, open-loop play, each task's scripted reference solver and
shared-parameter PPO (in tiers of budget) on every shipped scenario and task stream, seed
by seed, one small JSON file per seed.

    python -m baselines.benchmark                        # the smoke tier: all not yet done
    python -m baselines.benchmark --tier standard        # 1M agent-steps x 5 seeds
    python -m baselines.benchmark --methods random scripted open_loop
    python -m baselines.benchmark --only fruits_poisons coop_carry --methods ppo

``make benchmark [TIER=standard]`` runs it, then ``python -m baselines.benchmark_table``,
which writes docs/benchmark.md from the JSON files alone.

A task is a shipped scenario (``flatland_ma.list_scenarios()``) or a shipped stream
(``scenarios/streams/``). Each method plays it on the same held-out episodes:

- a scenario: ``episodes`` episodes reset with seeds ``eval_seed``, ``eval_seed + 1``, ...
  (apart from every training world); its score is the mean return per agent that the
  scenario's reference counts (every agent; with ``carrier_vs_random``, the first team's,
  the others playing at random);
- a stream of tasks: each task's world, episodes seeded as ``baselines.lifelong``'s
  evaluation blocks seed them, every agent played by the method; its score is the mean over
  the stream's tasks of the mean return per agent (the "average performance" at the end
  of a life). The never-ending stream is scored on its first ``never_ending_steps`` steps.

Methods: ``random`` (every agent uniform at random, seeded by the seed), ``scripted`` (the
reference solver ``flatland_ma.policies.scores_header.solver_names`` gives each agent, seeded by the
seed), ``open_loop`` (actions by the time step alone: the best of a few random schedules on
training episodes, ``baselines.open_loop``) and ``ppo``: ``baselines.ppo`` on a scenario,
``baselines.lifelong --method finetune`` through a stream of tasks and
``baselines.never_ending`` through the never-ending one, for the task's budget of
agent-steps (``baselines/benchmark.yaml``), then the final checkpoint is scored (a stream
of tasks: by its learner's last evaluation block).

PPO runs in tiers (``--tier``; ``baselines/benchmark.yaml``): ``smoke`` (100k agent-steps
x 3 seeds, regressions only), ``standard`` (1M x 5 seeds, every task in the best shipped
configuration for it, each named) and ``certificate`` (10M x 3 seeds, the tasks the
settings list). Random, scripted and open-loop play do not depend on a budget: their
results serve every tier.

Each result goes to ``<out>/<task>/<method>/seed_<k>.json`` (a tier other than smoke:
``<out>/<task>/ppo/<tier>/seed_<k>.json``): the score, each episode's, the budget,
agent-steps, the configuration's name and options, CPU and wall seconds, a calibration
(a fixed matrix product timed at the start of the run, ``baselines.bench_learn``), the
version of every scenario the task plays, package versions, commit and the machine's
load; PPO on a scenario also its learning curve (``baselines.benchmark_curves``). A seed
whose file exists is skipped, so an interrupted run resumes. Results of different
versions of a task never mix: a seed file of another version than the task's today stops
the run (``VersionMismatch``), and ``baselines.benchmark_table`` refuses a task whose
files disagree. A file written before tasks carried versions counts as version 0 of every
scenario it plays. Checkpoints and logs go to ``<runs>/<task>/`` (a tier other than smoke:
``<runs>/<tier>/<task>/``; not committed).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import os
import platform
import resource
import subprocess
import time
from importlib import metadata
from pathlib import Path

import numpy as np

from baselines.benchmark_config import (
    LEARNED,
    METHODS,
    TIERS,
    BenchmarkConfig,
    TaskConfig,
    curriculum_path,
    load_config,
)
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.policies.named import make_policy
from flatland_ma.policies.rollout import play_episode
from flatland_ma.policies.scores_header import solver_names

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "results" / "benchmark"
RUNS = ROOT / "runs" / "benchmark"
STREAM_EVALUATION_STRIDE = 1000
"""``baselines.lifelong`` seeds task i's evaluation worlds from EVALUATION_SEED + 1000 i."""


def list_tasks() -> list[tuple[str, str]]:
    """Every shipped (name, kind): the scenarios, then the streams."""
    import flatland_ma
    from flatland_ma.lifelong import list_streams

    return [(n, "scenario") for n in flatland_ma.list_scenarios()] + [
        (n, "stream") for n in list_streams()
    ]


# -- playing held-out episodes -----------------------------------------------------------


def scored_agents(env: FlatlandParallelEnv) -> list[str]:
    """The agents whose returns the scenario's reference counts: the first team's against
    random play (``carrier_vs_random``), otherwise every agent."""
    reference = env.spec.reference
    if reference is not None and reference.solver == "carrier_vs_random":
        first = env.spec.teams[0]
        return [a for i, a in enumerate(env.possible_agents) if env.spec.team_of(i) is first]
    return list(env.possible_agents)


def policy_names(env: FlatlandParallelEnv, method: str, checkpoint: str = "") -> dict[str, str]:
    """The policy each agent plays under ``method``; agents the score does not count play
    at random, as in the reference."""
    scored = scored_agents(env)
    if method == "random":
        return dict.fromkeys(env.possible_agents, "random")
    if method == "scripted":
        return solver_names(env)
    if method == "open_loop":
        checkpoint = "open_loop"
    return {a: checkpoint if a in scored else "random" for a in env.possible_agents}


UNSEEDED = frozenset({"greedy", "planner", "carrier"})
"""Shipped solvers that draw no random numbers: every seed of theirs plays alike, so a task
played by these alone is scored for one scripted seed."""


def scripted_seeds(name: str, kind: str, config: BenchmarkConfig) -> int:
    """Seeds of the scripted method on a task: one if every agent's solver is unseeded."""
    if kind == "scenario":
        worlds = [FlatlandParallelEnv(name)]
    else:
        worlds = [env for _, env, _ in stream_parts(name, config)]
    try:
        seeded = any(set(solver_names(env).values()) - UNSEEDED for env in worlds)
    finally:
        for env in worlds:
            env.close()
    return config.seeds if seeded else 1


def play_episodes(env: FlatlandParallelEnv, names: dict[str, str], seeds, seed: int) -> list[float]:
    """The score of each episode (reset with each of ``seeds``): the mean return of the
    scored agents, every agent playing its policy from ``names`` (seeded from ``seed``)."""
    agents = env.possible_agents
    policies = {
        a: make_policy(names[a], env, a, seed=seed * 1000 + agents.index(a)) for a in agents
    }
    return play_policies(env, policies, seeds)


def play_policies(env: FlatlandParallelEnv, policies: dict, seeds) -> list[float]:
    """The score of each episode (reset with each of ``seeds``), ``policies[agent]``
    acting for each agent."""
    scored = scored_agents(env)
    out = []
    for s in seeds:
        totals, _ = play_episode(env, policies, int(s))
        out.append(float(np.mean([totals[a] for a in scored])))
    return out


def play_open_loop(env: FlatlandParallelEnv, seeds, seed: int, config, first_seed: int):
    """Open-loop play (``baselines.open_loop``): the scored agents' best schedule (drawn
    from ``seed``) on training episodes from ``first_seed``, the others at random; (its
    score on each of ``seeds``, the search's record)."""
    from baselines.open_loop import OpenLoopPolicy, best_of

    agents = env.possible_agents
    names = policy_names(env, "open_loop")
    others = {
        a: make_policy(names[a], env, a, seed=seed * 1000 + agents.index(a))
        for a in agents
        if names[a] != "open_loop"
    }
    planned = [a for a in agents if names[a] == "open_loop"]

    def play(policies: dict, episode_seeds) -> list[float]:
        return play_policies(env, {**others, **policies}, episode_seeds)

    plan, search = best_of(env, planned, play, config.open_loop, seed, first_seed)
    return play({a: OpenLoopPolicy(s) for a, s in plan.items()}, seeds), search


def scenario_seeds(config: BenchmarkConfig) -> list[int]:
    return list(range(config.eval_seed, config.eval_seed + config.episodes))


def stream_parts(name: str, config: BenchmarkConfig):
    """Each task of stream ``name``: (label, its world, its held-out seeds)."""
    from baselines.lifelong import EVALUATION_SEED
    from flatland_ma.lifelong import load_stream, task_env

    stream = load_stream(name)
    for i, label in enumerate(stream.task_labels):
        env = task_env(stream, i)
        if stream.never_ending:
            env.step_limit = config.never_ending_steps
        first = EVALUATION_SEED + STREAM_EVALUATION_STRIDE * i
        yield label, env, list(range(first, first + config.episodes))


def play_task(name: str, kind: str, method: str, seed: int, config, checkpoint: str = ""):
    """(score, each episode's score, each stream task's score) of ``method`` on a task
    (not ``open_loop``: ``play_open_loop_task``)."""
    if kind == "scenario":
        env = FlatlandParallelEnv(name)
        try:
            episodes = play_episodes(
                env, policy_names(env, method, checkpoint), scenario_seeds(config), seed
            )
        finally:
            env.close()
        return float(np.mean(episodes)), episodes, {}
    parts: dict[str, float] = {}
    episodes = []
    for label, env, seeds in stream_parts(name, config):
        try:
            scores = play_episodes(env, policy_names(env, method, checkpoint), seeds, seed)
        finally:
            env.close()
        parts[label] = float(np.mean(scores))
        episodes += scores
    return float(np.mean(list(parts.values()))), episodes, parts


def play_open_loop_task(name: str, kind: str, seed: int, config):
    """(score, each episode's score, each stream task's score, each search's record) of
    open-loop play on a task: a stream's tasks each searched on their own episodes."""
    from baselines.open_loop import OPEN_LOOP_SEED

    if kind == "scenario":
        env = FlatlandParallelEnv(name)
        try:
            episodes, search = play_open_loop(
                env, scenario_seeds(config), seed, config, OPEN_LOOP_SEED
            )
        finally:
            env.close()
        return float(np.mean(episodes)), episodes, {}, {name: search}
    parts: dict[str, float] = {}
    searches: dict[str, dict] = {}
    episodes = []
    for i, (label, env, seeds) in enumerate(stream_parts(name, config)):
        try:
            first = OPEN_LOOP_SEED + STREAM_EVALUATION_STRIDE * i
            scores, searches[label] = play_open_loop(env, seeds, seed, config, first)
        finally:
            env.close()
        parts[label] = float(np.mean(scores))
        episodes += scores
    return float(np.mean(list(parts.values()))), episodes, parts, searches


# -- PPO ---------------------------------------------------------------------------------


def train_scenario(name: str, seed: int, task: TaskConfig, runs: Path) -> tuple[str, int]:
    """``baselines.ppo`` on scenario ``name`` for the task's budget: (checkpoint, agent-steps)."""
    from baselines import ppo
    from flatland_ma.policies.checkpoint import SUFFIX

    log = runs / name / "ppo" / f"seed_{seed}.csv"
    args = ppo_args(name, seed, task, log)
    summary = ppo.main(args)
    return str(log.with_suffix(SUFFIX)), int(summary["steps"])


def ppo_args(name: str, seed: int, task: TaskConfig, log: Path):
    """``baselines.ppo``'s arguments for a task: its options, the budget and the log. A
    preset's settings are applied here, beneath the task's own options, and the budget
    then set (a preset that names a length of run would otherwise replace a budget equal
    to the learner's default); a curriculum's file is found from the checkout."""
    from baselines import ppo
    from baselines.ppo_presets import with_preset

    options = {"tensorboard": False, "checkpoint_every": 0, **task.ppo}
    if options.get("curriculum"):
        options["curriculum"] = str(curriculum_path(options["curriculum"]))
    args = with_preset(ppo.Args(scenario=name, seed=seed, csv=str(log), **options))
    return dataclasses.replace(args, preset="", total_timesteps=task.budget)


def train_stream(name: str, seed: int, task: TaskConfig, runs: Path, config) -> tuple[dict, int]:
    """``baselines.lifelong --method finetune`` through stream ``name``, its life scaled to
    the task's budget, with one evaluation block at the start and one at the end: (each
    task's mean return in the last block, agent-steps)."""
    from baselines import lifelong
    from flatland_ma.lifelong import load_stream

    stream = load_stream(name)
    if stream.never_ending:
        raise ValueError(f"{name}: baselines.lifelong lives only streams of tasks")
    length = stream.length
    assert length is not None
    out = runs / name
    options = {"tensorboard": False, **task.ppo}
    args = lifelong.Args(
        stream=name,
        method="finetune",
        seed=seed,
        out=str(out),
        scale=task.budget / length,
        eval_every=10 * task.budget,
        eval_episodes=config.episodes,
        **options,
    )
    summary = lifelong.main(args)
    with open(out / "finetune" / f"seed_{seed}" / "evaluations.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    last = max(int(r["step"]) for r in rows)
    labels = stream.task_labels
    parts = {
        labels[int(r["task"])]: float(r["mean_return"]) for r in rows if int(r["step"]) == last
    }
    return parts, int(summary["agent_steps"])


# -- records -----------------------------------------------------------------------------


class VersionMismatch(ValueError):
    """Results of a task's other version where this one's would go, or beside them."""


def task_versions(name: str, kind: str) -> dict[str, int]:
    """The version of every scenario a task plays, by scenario: the scenario itself, or
    each scenario of a stream's tasks (with the stream's overrides, as it plays them)."""
    if kind == "scenario":
        from flatland_ma.scenario.loader import load_scenario

        return {name: load_scenario(name).version}
    from flatland_ma.lifelong import load_stream

    stream = load_stream(name)
    spec = stream.spec
    named = [t.scenario for t in spec.tasks] if spec.tasks else [spec.never_ending.scenario]
    return {str(n): scenario.version for n, scenario in zip(named, stream.scenarios)}


def recorded_versions(record: dict, today: dict[str, int]) -> dict[str, int]:
    """The scenario versions a result was made on (a record from before tasks carried
    versions: version 0 of each scenario the task plays today)."""
    return record.get("task_versions", dict.fromkeys(today, 0))


def check_versions(path: Path, today: dict[str, int]) -> None:
    """``VersionMismatch`` if the result at ``path`` was made on other versions."""
    made = recorded_versions(json.loads(path.read_text(encoding="utf-8")), today)
    if made != today:
        raise VersionMismatch(
            f"{path} was made on {versions_text(made)}, the task is now {versions_text(today)}: "
            "results of different versions never mix; move the task's old results away "
            "and run it again"
        )


def versions_text(versions: dict[str, int]) -> str:
    """``{"fruits_poisons": 1}`` -> ``fruits_poisons v1``."""
    return ", ".join(f"{name} v{version}" for name, version in sorted(versions.items()))


def versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for package in ("flatland_ma", "numpy", "pymunk", "numba", "torch"):
        try:
            out[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            out[package] = "absent"
    return out


def commit() -> str:
    """The checkout's commit, with ``-modified`` if the library or the baselines differ from it."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
        )
        changed = subprocess.run(
            ["git", "diff", "--quiet", "HEAD", "--", "flatland_ma", "baselines", "scenarios"],
            cwd=ROOT,
        )
    except OSError:
        return "unknown"
    name = head.stdout.strip() or "unknown"
    return name + ("-modified" if changed.returncode == 1 else "")


def machine() -> dict:
    return {
        "load_1min": round(os.getloadavg()[0], 2),
        "cpus_usable": len(os.sched_getaffinity(0)),
        "cpus": os.cpu_count(),
        "machine": platform.machine(),
    }


def cpu_seconds() -> float:
    """CPU time of this process (every thread) and of its finished children."""
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def calibrate() -> dict:
    """The machine's speed at the start of a run: ``baselines.bench_learn.calibration``'s
    fixed matrix products, per CPU-second of this thread."""
    from baselines.bench_learn import calibration

    return {"matmuls_256_per_cpu_second": round(calibration(), 1)}


def run_one(
    name: str, kind: str, method: str, seed: int, config, runs: Path, tier: str = "smoke"
) -> dict:
    """Play (and for PPO first train) one seed of one method on one task: its record
    (PPO's in ``tier``, training under ``runs``)."""
    task = config.task(name, tier)
    calibration = calibrate()
    load_before, cpu, wall = machine(), cpu_seconds(), time.perf_counter()
    budget, steps, checkpoint, learnt = 0, 0, "", None
    search = None
    if method == "ppo" and kind == "scenario":
        budget = task.budget
        checkpoint, steps = train_scenario(name, seed, task, runs)
    if method == "ppo" and kind == "stream" and never_ending(name):
        from baselines import never_ending as endless

        budget = task.budget
        checkpoint, steps = endless.train(name, seed, task.budget, dict(task.ppo), runs)
        score, episodes, parts = play_task(name, kind, method, seed, config, checkpoint)
    elif method == "ppo" and kind == "stream":
        budget = task.budget
        learnt, steps = train_stream(name, seed, task, runs, config)
        score, episodes, parts = float(np.mean(list(learnt.values()))), [], learnt
    elif method == "open_loop":
        score, episodes, parts, search = play_open_loop_task(name, kind, seed, config)
    else:
        score, episodes, parts = play_task(name, kind, method, seed, config, checkpoint)
    record = {
        "task": name,
        "kind": kind,
        "task_versions": task_versions(name, kind),
        "method": method,
        "seed": seed,
        "score": round(score, 6),
        "episodes": [round(e, 6) for e in episodes],
        "parts": {k: round(v, 6) for k, v in parts.items()},
        "eval_episodes": config.episodes,
        "budget": budget,
        "agent_steps": steps,
        "options": dict(task.ppo) if method == "ppo" else {},
        "cpu_seconds": round(cpu_seconds() - cpu, 2),
        "wall_seconds": round(time.perf_counter() - wall, 2),
        "versions": versions(),
        "commit": commit(),
        "machine": {"before": load_before, "after": machine()},
    }
    record.update(run_fields(method, kind, tier, task, calibration, runs / name, seed, search))
    return record


def run_fields(method, kind, tier, task, calibration, runs: Path, seed: int, search) -> dict:
    """A record's fields beyond the score: the machine's calibration; PPO's tier,
    configuration and (on a scenario) learning curve from its log under ``runs``; the
    open-loop search."""
    from baselines.benchmark_curves import seed_curve

    out: dict = {"calibration": calibration}
    if method in LEARNED:
        out["tier"] = tier
        out["configuration"] = task.name
    if method == "ppo" and kind == "scenario":
        out["curve"] = seed_curve(runs / "ppo" / f"seed_{seed}.csv", task.budget)
    if search is not None:
        out["open_loop"] = search
    return out


def result_path(out: Path, name: str, method: str, seed: int, tier: str = "smoke") -> Path:
    """A seed's result: ``<out>/<task>/<method>/seed_<k>.json``, or for a learned method
    in a tier other than smoke ``<out>/<task>/<method>/<tier>/seed_<k>.json``."""
    if method in LEARNED and tier != "smoke":
        return out / name / method / tier / f"seed_{seed}.json"
    return out / name / method / f"seed_{seed}.json"


def tier_runs(runs: Path, tier: str) -> Path:
    """Where a tier's checkpoints and logs go: ``runs`` for smoke, ``runs/<tier>`` else."""
    return runs if tier == "smoke" else runs / tier


def write_record(path: Path, record: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_suffix(".part")
    part.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    part.replace(path)


def ppo_possible(name: str, kind: str) -> bool:
    """Whether a shipped learner can train on the task: every scenario and every stream
    (a stream of tasks through ``baselines.lifelong``, the never-ending one through
    ``baselines.never_ending``)."""
    return kind in ("scenario", "stream")


def never_ending(name: str) -> bool:
    from flatland_ma.lifelong import load_stream

    return bool(load_stream(name).never_ending)


def run(
    config,
    tasks,
    methods,
    out: Path = OUT,
    runs: Path = RUNS,
    hours: float = 0.0,
    tier: str = "smoke",
):
    """Every method (in order) on every task, every seed not yet written; the files written.
    PPO runs ``tier``'s seeds on its tasks; the other methods serve every tier. With
    ``hours``, no seed is started after that many hours (a bounded session).
    ``VersionMismatch`` before anything runs if a task's results in ``out`` were made on
    other versions of its scenarios than today's."""
    written: list[Path] = []
    stop = time.monotonic() + hours * 3600.0 if hours else float("inf")
    for name, kind in tasks:  # before anything runs: no result of another version beside
        today = task_versions(name, kind)
        for path in sorted((out / name).rglob("seed_*.json")):
            check_versions(path, today)
    level = config.tier(tier)
    for method in methods:
        for name, kind in tasks:
            if method == "ppo" and not (ppo_possible(name, kind) and level.runs(name)):
                continue
            seeds = level.seeds if method in LEARNED else config.seeds
            if method == "scripted":
                seeds = scripted_seeds(name, kind, config)
            for seed in range(seeds):
                path = result_path(out, name, method, seed, tier)
                if path.exists():
                    continue
                if time.monotonic() > stop:
                    print("benchmark: out of time; run it again to go on", flush=True)
                    return written
                print(
                    f"benchmark: {name} {method} seed {seed}"
                    + (f" ({tier})" if method in LEARNED else ""),
                    flush=True,
                )
                record = run_one(name, kind, method, seed, config, tier_runs(runs, tier), tier)
                write_record(path, record)
                written.append(path)
                print(
                    f"benchmark: {name} {method} seed {seed}: score {record['score']:.4g} "
                    f"({record['cpu_seconds']:.0f} CPU s)",
                    flush=True,
                )
    return written


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--config", default=str(ROOT / "baselines" / "benchmark.yaml"))
    parser.add_argument(
        "--tier", choices=TIERS, default="smoke", help="PPO's budgets and seeds (default smoke)"
    )
    parser.add_argument("--only", nargs="+", default=None, help="these tasks only")
    parser.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    parser.add_argument("--out", default=str(OUT), help="where the JSON results go")
    parser.add_argument("--runs", default=str(RUNS), help="where checkpoints and logs go")
    parser.add_argument(
        "--hours", type=float, default=0.0, help="start no seed after this many hours (0: none)"
    )
    args = parser.parse_args(argv)
    tasks = list_tasks()
    if args.only:
        known = {name for name, _ in tasks}
        unknown = sorted(set(args.only) - known)
        if unknown:
            parser.error(f"no shipped scenario or stream {', '.join(unknown)}")
        tasks = [t for t in tasks if t[0] in args.only]
    config = load_config(args.config)
    if args.tier not in config.tiers:
        parser.error(f"{args.config}: tiers: no tier {args.tier}")
    shipped = {name for name, _ in list_tasks()}
    for name, level in config.tiers.items():
        strangers = sorted((set(level.tasks) | set(level.only or [])) - shipped)
        if strangers:
            parser.error(
                f"{args.config}: tiers.{name}: no shipped scenario or stream "
                + ", ".join(strangers)
            )
    run(config, tasks, args.methods, Path(args.out), Path(args.runs), args.hours, args.tier)


if __name__ == "__main__":
    main()
