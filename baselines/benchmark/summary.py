"""The benchmark's figures from its per-seed records: per task and tier, each method's
interquartile mean over seeds with a 95% stratified bootstrap interval
(``flatland_ma.evaluation.stats``), PPO's and open-loop play's normalised (random play 0,
the scripted reference 1), the verdict and whether PPO beats open-loop play; per tier, the
aggregate over tasks. No training: the records alone (``baselines.benchmark.records``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from baselines.benchmark.levels import read_levels
from baselines.benchmark.play import list_tasks
from baselines.benchmark.reach import REACH
from baselines.benchmark.records import check_current, read_results
from baselines.benchmark.settings import LEARNED, METHODS, NO_CHANNEL, TIERS, BenchmarkConfig
from baselines.benchmark.train import ppo_possible
from baselines.benchmark.within_reach import IMITATION, read_imitation
from flatland_ma.evaluation.stats import normalise, stratified_bootstrap

SCALE_GAP = 1e-6
"""Scripted play must beat random play by more than this (relative to their size) for a
task to be normalised; below it the scale would divide by about zero."""


VERDICTS = {
    "beyond scripted": "PPO's whole interval lies above the scripted score (lower bound > 1)",
    "solved": "PPO's IQM reaches the scripted score (>= 1)",
    "close to scripted": "PPO's IQM is between half the scripted score and it, and its "
    "interval reaches 1",
    "open": "PPO's IQM is below half the scripted score (< 0.5), or its whole interval lies "
    "below 1",
}


def interval(scores) -> dict:
    """IQM over seeds and its 95% bootstrap interval."""
    point, low, high = stratified_bootstrap([[float(s) for s in scores]])
    return {"iqm": point, "low": low, "high": high, "seeds": len(scores)}


def has_scale(random: float, scripted: float) -> bool:
    return scripted - random > SCALE_GAP * max(1.0, abs(random), abs(scripted))


def verdict(normalised: dict | None) -> str:
    if normalised is None:
        return ""
    if normalised["low"] > 1.0:
        return "beyond scripted"
    if normalised["iqm"] >= 1.0:
        return "solved"
    if normalised["iqm"] < 0.5 or normalised["high"] < 1.0:
        return "open"
    return "close to scripted"


def against_open_loop(ppo: dict | None, open_loop: dict | None) -> str:
    """Whether PPO beats open-loop play (or any other method) on a task, by their
    intervals over seeds (raw scores): "yes" (PPO's lower bound above open-loop's upper),
    "no" (PPO's upper bound below open-loop's lower) or "not shown" (they overlap); "" if
    either is missing."""
    if ppo is None or open_loop is None:
        return ""
    if ppo["low"] > open_loop["high"]:
        return "yes"
    if ppo["high"] < open_loop["low"]:
        return "no"
    return "not shown"


def run_line(record: dict) -> dict:
    """One PPO seed's cost and conditions, for the page's list of runs."""
    calibration = record.get("calibration") or {}
    loads = record.get("machine") or {}
    return {
        "seed": record["seed"],
        "agent_steps": record["agent_steps"],
        "cpu_seconds": record["cpu_seconds"],
        "wall_seconds": record.get("wall_seconds"),
        "load": [loads.get(k, {}).get("load_1min") for k in ("before", "after")],
        "calibration": calibration.get("matmuls_256_per_cpu_second"),
        "commit": record["commit"],
    }


def task_row(
    name: str, kind: str, methods: dict[str, list[dict]], config, tier: str = "smoke"
) -> dict:
    """One task's figures in ``tier``: each method's IQM and interval over seeds (raw
    scores), PPO's and open-loop play's normalised, the verdict, PPO against open-loop
    play, the budget, the configuration and PPO's CPU seconds and runs."""
    task = config.task(name, tier)
    row: dict = {"task": name, "kind": kind, "budget": task.budget, "configuration": task.name}
    for method in METHODS:
        records = methods.get(method, [])
        row[method] = interval([r["score"] for r in records]) if records else None
    if methods.get("ppo"):
        row["budget"] = methods["ppo"][0]["budget"]
        row["configuration"] = methods["ppo"][0].get("configuration", task.name)
    row["learner"] = ppo_possible(name, kind) and config.tier(tier).runs(name)
    row["cpu_seconds"] = round(sum(r["cpu_seconds"] for r in methods.get("ppo", [])), 2)
    row["runs"] = [run_line(r) for r in methods.get("ppo", [])]
    row["normalised"], row["scale"], row["open_loop_normalised"] = None, None, None
    if row["random"] and row["scripted"]:
        low = float(np.mean([r["score"] for r in methods["random"]]))
        high = float(np.mean([r["score"] for r in methods["scripted"]]))
        row["scale"] = {"random": low, "scripted": high, "ok": has_scale(low, high)}
        if row["scale"]["ok"] and row["ppo"]:
            scores = normalise([r["score"] for r in methods["ppo"]], low, high)
            row["normalised"] = interval(scores)
            row["normalised_seeds"] = [float(s) for s in scores]
        if row["scale"]["ok"] and row["open_loop"]:
            scores = normalise([r["score"] for r in methods["open_loop"]], low, high)
            row["open_loop_normalised"] = interval(scores)
    row["verdict"] = verdict(row["normalised"])
    row["beats_open_loop"] = against_open_loop(row["ppo"], row["open_loop"])
    row.update(ablation(name, kind, methods.get(NO_CHANNEL, []), config, tier))
    row["channel_helps"] = against_open_loop(row["ppo"], row[NO_CHANNEL])
    return row


def ablation(name: str, kind: str, records: list[dict], config, tier: str) -> dict:
    """The channel's ablation on a task (``NO_CHANNEL``, its seeds' ``records``): whether
    the tier runs it there, its configuration and its seeds' CPU seconds."""
    return {
        "no_channel_learner": ppo_possible(name, kind, NO_CHANNEL) and config.tier(tier).runs(name),
        "no_channel_configuration": records[0]["configuration"]
        if records
        else config.task(name, tier, NO_CHANNEL).name,
        "no_channel_cpu_seconds": [r["cpu_seconds"] for r in records],
    }


def task_rates(tiers: dict[str, dict]) -> dict[str, float]:
    """Each task's PPO agent-steps per CPU-second (training and scoring) over its records
    of every tier (``tiers``: each tier's results, as ``read_results`` gives them)."""
    steps: dict[str, float] = {}
    seconds: dict[str, float] = {}
    for results in tiers.values():
        for task, methods in results.items():
            for r in methods.get("ppo", []):
                steps[task] = steps.get(task, 0.0) + r["agent_steps"]
                seconds[task] = seconds.get(task, 0.0) + r["cpu_seconds"]
    return {t: steps[t] / seconds[t] for t in steps if steps[t] > 0 and seconds[t] > 0}


def build_tier(
    results: dict, config: BenchmarkConfig, tier: str, tasks, rates: dict | None = None
) -> dict:
    """One tier's rows and aggregate over tasks; ``rates`` (``task_rates``) price the
    tier's training in CPU-hours, the whole and what is still to run."""
    level = config.tier(tier)
    for name, kind in tasks:
        check_current(name, kind, results.get(name, {}))
    rows = [task_row(n, k, results.get(n, {}), config, tier) for n, k in tasks]
    scored = [r["normalised_seeds"] for r in rows if r["normalised"] is not None]
    aggregate = None
    if scored:
        point, low, high = stratified_bootstrap(scored)
        aggregate = {"iqm": point, "low": low, "high": high, "tasks": len(scored)}
    ppo = [r for methods in results.values() for r in methods.get("ppo", [])]
    planned = sum(r["budget"] * level.seeds for r in rows if r["learner"])
    rate = sum(r["agent_steps"] for r in ppo) / max(1e-9, sum(r["cpu_seconds"] for r in ppo))
    hours = planned_hours(rows, level.seeds, rates or {}, rate if ppo else None)
    return {
        "tier": tier,
        "rows": rows,
        "seeds": level.seeds,
        "budget": level.default.budget,
        "only": level.only,
        "planned_steps": planned,
        "ppo_rate": round(rate, 1) if ppo else None,
        "planned_hours": hours,
        "ppo_seconds": round(sum(r["cpu_seconds"] for r in ppo), 1),
        "aggregate": aggregate,
        "half": sum(r["normalised"] is not None and r["normalised"]["iqm"] >= 0.5 for r in rows),
    }


def planned_hours(rows: list, seeds: int, rates: dict, pooled: float | None) -> dict | None:
    """The CPU-hours of the tier's PPO training, ``whole`` and ``left`` to run (the seeds
    not yet written), each task at its own rate (``rates``: in this tier where it has
    seeds in it, else in the others; the tier's pooled rate for a task with none); None if
    no rate is known."""
    whole = left = 0.0
    for r in rows:
        rate = rates.get(r["task"], pooled)
        if not r["learner"]:
            continue
        if not rate:
            return None
        done = r["ppo"]["seeds"] if r["ppo"] else 0
        whole += r["budget"] * seeds / rate / 3600
        left += r["budget"] * max(0, seeds - done) / rate / 3600
    return {"whole": round(whole, 4), "left": round(left, 4)}


def read_reach(path: Path) -> dict | None:
    """Where each task's reward lies (``baselines.benchmark.reach``), if measured."""
    return json.loads(path.read_text(encoding="utf-8")) if path.exists() else None


def build(root: Path, config: BenchmarkConfig, tasks=None, levels: Path | None = None) -> dict:
    """Every tier's rows and aggregate over tasks, from the JSON under ``root`` (and the
    level runs under ``levels``, if given; and where each task's reward lies, from
    ``reach.json`` beside ``root``, if there)."""
    tasks = tasks or list_tasks()
    tiers, records = {}, []
    read = {tier: read_results(root, tier) for tier in TIERS if tier in config.tiers}
    rates = task_rates(read)
    for tier, results in read.items():  # a task's rate in the tier itself, where it has one
        own = {**rates, **task_rates({tier: results})}
        tiers[tier] = build_tier(results, config, tier, tasks, own)
        records += [
            r
            for methods in results.values()
            for m, rs in methods.items()
            for r in rs
            if m in LEARNED or tier == "smoke"
        ]
    totals = {
        method: round(sum(r["cpu_seconds"] for r in records if r["method"] == method), 1)
        for method in METHODS
    }
    return {
        "tiers": tiers,
        "cpu_seconds": totals,
        "commits": sorted({r["commit"] for r in records}),
        "versions": sorted({json.dumps(r["versions"], sort_keys=True) for r in records}),
        "seeds": config.seeds,
        "episodes": config.episodes,
        "open_loop": config.open_loop.model_dump(),
        "levels": read_levels(levels) if levels is not None else None,
        "reach": read_reach(root.parent / REACH.name),
        "imitation": read_imitation(root.parent / IMITATION.name),
    }


def scenario_summary(summary: dict) -> dict:
    """Each task's figures, for the catalogue's pages (``results/benchmark/summary.json``):
    those of the largest tier with PPO results on it (smoke's if none), and each tier's."""
    keep = ("kind", "budget", "random", "scripted", "ppo", "normalised", "verdict", "learner")
    keep += ("configuration", "open_loop", "beats_open_loop")
    out: dict = {}
    for tier in summary["tiers"].values():
        for r in tier["rows"]:
            figures = {k: r[k] for k in keep}
            entry = out.setdefault(r["task"], {**figures, "tier": tier["tier"], "tiers": {}})
            if r["ppo"] is not None:
                entry.update(figures, tier=tier["tier"])
                entry["tiers"][tier["tier"]] = {
                    k: r[k] for k in ("budget", "configuration", "ppo", "normalised", "verdict")
                }
    return out
