"""The benchmark's runs: every method on every task, seed by seed, each seed's record
written to its JSON file (``baselines.benchmark.records``); a seed whose file exists is
skipped, so an interrupted run resumes. The command is ``python -m baselines.benchmark``."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from baselines.benchmark.curves import seed_curve
from baselines.benchmark.machine import calibrate, commit, cpu_seconds, machine, versions
from baselines.benchmark.play import play_open_loop_task, play_task, scripted_seeds
from baselines.benchmark.records import (
    OUT,
    RUNS,
    check_configuration,
    check_versions,
    result_path,
    task_versions,
    tier_runs,
    write_record,
)
from baselines.benchmark.settings import LEARNED
from baselines.benchmark.train import never_ending, ppo_possible, train_scenario, train_stream


def run_one(
    name: str, kind: str, method: str, seed: int, config, runs: Path, tier: str = "smoke"
) -> dict:
    """Play (and for PPO first train) one seed of one method on one task: its record
    (PPO's in ``tier``, training under ``runs``)."""
    task = config.task(name, tier, method)
    calibration = calibrate()
    load_before, cpu, wall = machine(), cpu_seconds(), time.perf_counter()
    budget, steps, checkpoint, learnt = 0, 0, "", None
    search, resumed = None, {}
    if method in LEARNED and kind == "scenario":
        budget = task.budget
        checkpoint, steps, resumed = train_scenario(name, seed, task, runs, method)
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
    earlier = resumed.get("earlier_seconds", {})
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
        "options": dict(task.ppo) if method in LEARNED else {},
        "cpu_seconds": round(cpu_seconds() - cpu + earlier.get("cpu", 0.0), 2),
        "wall_seconds": round(time.perf_counter() - wall + earlier.get("wall", 0.0), 2),
        "versions": versions(),
        "commit": commit(),
        "machine": {"before": load_before, "after": machine()},
    }
    record.update(run_fields(method, kind, tier, task, calibration, runs / name, seed, search))
    if "resumed_at" in resumed:  # trained in more than one process
        record["resumed_at"] = resumed["resumed_at"]
    return record


def run_fields(method, kind, tier, task, calibration, runs: Path, seed: int, search) -> dict:
    """A record's fields beyond the score: the machine's calibration; PPO's tier,
    configuration and (on a scenario) learning curve from its log under ``runs``; the
    open-loop search."""
    out: dict = {"calibration": calibration}
    if method in LEARNED:
        out["tier"] = tier
        out["configuration"] = task.name
    if method in LEARNED and kind == "scenario":
        out["curve"] = seed_curve(runs / method / f"seed_{seed}.csv", task.budget)
    if search is not None:
        out["open_loop"] = search
    return out


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
    other versions of its scenarios than today's, ``ConfigurationMismatch`` if a learned
    method's results of ``tier`` were trained in another configuration than it names."""
    written: list[Path] = []
    stop = time.monotonic() + hours * 3600.0 if hours else float("inf")
    level = config.tier(tier)
    for name, kind in tasks:  # before anything runs: no result of another version beside
        today = task_versions(name, kind)
        for path in sorted((out / name).rglob("seed_*.json")):
            check_versions(path, today)
        for method in LEARNED.intersection(methods):  # nor of another configuration
            for seed in range(level.seeds):
                path = result_path(out, name, method, seed, tier)
                if path.exists():
                    check_configuration(path, level.task(name, method).name)
    for method in methods:
        for name, kind in tasks:
            trained = method in LEARNED
            if trained and not (ppo_possible(name, kind, method) and level.runs(name)):
                continue
            seeds = level.seeds if trained else config.seeds
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
