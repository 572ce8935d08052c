"""The benchmark's page, docs/benchmark.md, rebuilt from the committed per-seed JSON files
alone (no training): every shipped scenario and stream, random / scripted / open-loop play
and PPO with 95% intervals, a section per tier of PPO (smoke, standard, certificate) with
its budgets, configurations, verdicts, whether PPO beats open-loop play, and each seed's
CPU time, load and calibration.

    python -m baselines.benchmark_table          # make benchmark-table

Scores are normalised per task, random play 0 and the scripted reference 1 (the means of
their seeds); a task whose scripted play does not beat random play has no scale, and the
page says so. Each figure is the interquartile mean over seeds with a 95% stratified
bootstrap interval (``flatland_ma.evaluation.stats``, as the evaluation suites report
them); a tier's aggregate pools the normalised PPO seeds of every task that has them.

Also written: ``results/benchmark/summary.json`` (each task's figures, which the
catalogue's scenario pages show), ``docs/images/benchmark.png`` (smoke) and
``benchmark_<tier>.png`` (the other tiers, once run), and each scenario's learning curve,
``docs/images/curves/<task>.png``, from the curves its PPO records hold
(``baselines.benchmark_curves``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from baselines.benchmark import (
    OUT,
    ROOT,
    VersionMismatch,
    list_tasks,
    ppo_possible,
    task_versions,
    versions_text,
)
from baselines.benchmark_config import LEARNED, METHODS, TIERS, BenchmarkConfig, load_config
from baselines.benchmark_curves import draw_curves, task_curve
from baselines.levels import LEVELS_OUT, read_levels, render_levels
from flatland_ma.evaluation.stats import normalise, stratified_bootstrap

PAGE = ROOT / "docs" / "benchmark.md"
CURVES = Path("images") / "curves"
"""Each scenario's learning curve, ``<task>.png``, under docs/."""
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


def _version_key(versions: dict | None) -> str:
    """One text per set of versions; a record from before tasks carried versions (None)
    counts as version 0 of every scenario."""
    versions = {k: v for k, v in (versions or {}).items() if v != 0}
    return versions_text(versions) if versions else "version 0"


def read_results(root: Path, tier: str = "smoke") -> dict[str, dict[str, list[dict]]]:
    """``{task: {method: [record of each seed, by seed]}}`` from ``root``'s JSON files: a
    learned method's records of ``tier`` (a record without a tier is smoke's), every
    other method's records; ``VersionMismatch`` if one task's files were made on
    different versions."""
    out: dict[str, dict[str, list[dict]]] = {}
    made: dict[str, dict[str, Path]] = {}
    paths = sorted(root.glob("*/*/seed_*.json")) + sorted(root.glob("*/*/*/seed_*.json"))
    for path in paths:
        record = json.loads(path.read_text(encoding="utf-8"))
        if record["method"] in LEARNED and record.get("tier", "smoke") != tier:
            continue
        out.setdefault(record["task"], {}).setdefault(record["method"], []).append(record)
        made.setdefault(record["task"], {}).setdefault(
            _version_key(record.get("task_versions")), path
        )
    for task, found in made.items():
        if len(found) > 1:
            (one, first), (other, second) = list(found.items())[:2]
            raise VersionMismatch(
                f"results of {task} were made on different versions: {first} on {one}, "
                f"{second} on {other}; results of different versions never mix"
            )
    for methods in out.values():
        for records in methods.values():
            records.sort(key=lambda r: r["seed"])
    return out


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
    """Whether PPO beats open-loop play on a task, by their intervals over seeds (raw
    scores): "yes" (PPO's lower bound above open-loop's upper), "no" (PPO's upper bound
    below open-loop's lower) or "not shown" (they overlap); "" if either is missing."""
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
    return row


def build_tier(results: dict, config: BenchmarkConfig, tier: str, tasks) -> dict:
    """One tier's rows and aggregate over tasks."""
    level = config.tier(tier)
    for name, kind in tasks:
        _check_current(name, kind, results.get(name, {}))
    rows = [task_row(n, k, results.get(n, {}), config, tier) for n, k in tasks]
    scored = [r["normalised_seeds"] for r in rows if r["normalised"] is not None]
    aggregate = None
    if scored:
        point, low, high = stratified_bootstrap(scored)
        aggregate = {"iqm": point, "low": low, "high": high, "tasks": len(scored)}
    ppo = [r for methods in results.values() for r in methods.get("ppo", [])]
    planned = sum(r["budget"] * level.seeds for r in rows if r["learner"])
    rate = sum(r["agent_steps"] for r in ppo) / max(1e-9, sum(r["cpu_seconds"] for r in ppo))
    return {
        "tier": tier,
        "rows": rows,
        "seeds": level.seeds,
        "budget": level.default.budget,
        "only": level.only,
        "planned_steps": planned,
        "ppo_rate": round(rate, 1) if ppo else None,
        "ppo_seconds": round(sum(r["cpu_seconds"] for r in ppo), 1),
        "aggregate": aggregate,
        "half": sum(r["normalised"] is not None and r["normalised"]["iqm"] >= 0.5 for r in rows),
    }


def build(root: Path, config: BenchmarkConfig, tasks=None, levels: Path | None = None) -> dict:
    """Every tier's rows and aggregate over tasks, from the JSON under ``root`` (and the
    level runs under ``levels``, if given)."""
    tasks = tasks or list_tasks()
    tiers, records = {}, []
    for tier in TIERS:
        if tier not in config.tiers:
            continue
        results = read_results(root, tier)
        tiers[tier] = build_tier(results, config, tier, tasks)
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
    }


def _check_current(name: str, kind: str, methods: dict[str, list[dict]]) -> None:
    """``VersionMismatch`` if a task's results were made on other versions than today's."""
    records = [r for rs in methods.values() for r in rs]
    today = _version_key(task_versions(name, kind))
    if records and _version_key(records[0].get("task_versions")) != today:
        made = _version_key(records[0].get("task_versions"))
        raise VersionMismatch(
            f"the results of {name} were made on {made}, the task is now {today}: run "
            "baselines.benchmark for it again (after moving its old results away)"
        )


# -- the page ----------------------------------------------------------------------------


def figure_text(x: dict | None) -> str:
    if x is None:
        return ""
    iqm, low, high = (0.0 if abs(x[k]) < 1e-12 else x[k] for k in ("iqm", "low", "high"))
    return f"{iqm:.3g} ({low:.3g} to {high:.3g})"


def ppo_cell(row: dict, seeds: int) -> str:
    if row["ppo"] is not None:
        done = row["ppo"]["seeds"]
        return figure_text(row["ppo"]) + (f", {done} of {seeds} seeds" if done < seeds else "")
    return "not yet run" if row["learner"] else "not in this tier"


def normalised_cell(row: dict, key: str = "normalised") -> str:
    if row[key] is not None:
        return figure_text(row[key])
    if row["scale"] is not None and not row["scale"]["ok"]:
        return "no scale: scripted does not beat random"
    return ""


def open_loop_cell(row: dict) -> str:
    answer = row["beats_open_loop"]
    return answer if answer in ("", "yes") else f"**{answer}**"


def solver_text(name: str, kind: str) -> str:
    if kind == "stream":
        return "each task's reference"
    from flatland_ma.scenario.loader import load_scenario

    reference = load_scenario(name).reference
    if reference is None:
        return ""
    if reference.teams:
        return f"{reference.solver}: {', '.join(reference.teams)}"
    return reference.solver


def markdown_table(headers: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    return out + ["| " + " | ".join(cells) + " |" for cells in rows]


def reference_table(rows: list[dict]) -> list[str]:
    """Random, scripted and open-loop play (the same in every tier)."""
    headers = ["Task", "Random", "Scripted", "Reference solver", "Open-loop"]
    headers += ["Open-loop, normalised"]
    return markdown_table(
        headers,
        [
            [
                f"`{r['task']}`",
                figure_text(r["random"]) or "not yet run",
                figure_text(r["scripted"]) or "not yet run",
                solver_text(r["task"], r["kind"]),
                figure_text(r["open_loop"]) or "not yet run",
                normalised_cell(r, "open_loop_normalised"),
            ]
            for r in rows
        ],
    )


def table(rows: list[dict], seeds: int) -> list[str]:
    """One tier's PPO figures per task."""
    headers = ["Task", "PPO", "PPO, normalised", "Beats open-loop", "Configuration"]
    headers += ["Budget", "CPU per seed", "Verdict"]
    out = []
    for r in rows:
        budget = f"{r['budget']:,}" if r["learner"] or r["ppo"] else "-"
        cpu = f"{r['cpu_seconds'] / len(r['runs']) / 60:.1f} min" if r["runs"] else ""
        out.append(
            [
                f"`{r['task']}`",
                ppo_cell(r, seeds),
                normalised_cell(r),
                open_loop_cell(r),
                r["configuration"] if r["learner"] or r["ppo"] else "-",
                budget,
                cpu,
                r["verdict"],
            ]
        )
    return markdown_table(headers, out)


def runs_table(rows: list[dict]) -> list[str]:
    """Every PPO seed of a tier: its cost, the machine's load and calibration."""
    out = []
    for r in rows:
        for run in r["runs"]:
            load = " to ".join("-" if x is None else f"{x:g}" for x in run["load"])
            calibration = run["calibration"]
            out.append(
                [
                    f"`{r['task']}`",
                    str(run["seed"]),
                    f"{run['agent_steps']:,}",
                    f"{run['cpu_seconds']:.0f}",
                    "-" if run["wall_seconds"] is None else f"{run['wall_seconds']:.0f}",
                    load,
                    "not recorded" if calibration is None else f"{calibration:.0f}",
                    f"`{run['commit']}`",
                ]
            )
    headers = ["Task", "Seed", "Agent-steps", "CPU s", "Wall s", "Load (1 min)"]
    headers += ["Calibration (matmuls/CPU-s)", "Commit"]
    return markdown_table(headers, out)


def planned_text(tier: dict) -> str:
    text = (
        f"The whole tier is {tier['planned_steps'] / 1e6:.3g}M agent-steps of PPO training "
        "(every budget times the seeds)"
    )
    rate = tier["ppo_rate"]
    if not rate:
        return text + "."
    hours = tier["planned_steps"] / rate / 3600
    return (
        text + f"; at the {rate:.0f} agent-steps per CPU-second its committed PPO seeds "
        f"averaged (training and scoring), about {hours:.1f} CPU-hours."
    )


TIER_TEXT = {
    "smoke": "regressions only: a short run of every task (the results without a tier)",
    "standard": "the published budgets' order of magnitude, every task, each in the best "
    "shipped configuration known for it",
    "certificate": "ten times the standard budget, for the tasks still open at it (the "
    "settings file lists them)",
}


def figure_path(tier: str) -> str:
    """A tier's figure, relative to docs/ (smoke's keeps the page's first name)."""
    return "images/benchmark.png" if tier == "smoke" else f"images/benchmark_{tier}.png"


def open_at_standard(summary: dict) -> list[str]:
    """Tasks below half the scripted score at the standard budget that the certificate
    tier does not run."""
    tiers = summary["tiers"]
    if "standard" not in tiers or "certificate" not in tiers:
        return []
    only = tiers["certificate"]["only"]
    return [
        r["task"]
        for r in tiers["standard"]["rows"]
        if r["normalised"] is not None
        and r["normalised"]["iqm"] < 0.5
        and only is not None
        and r["task"] not in only
    ]


def tier_section(tier: dict, summary: dict) -> list[str]:
    rows = tier["rows"]
    agg = tier["aggregate"]
    name = tier["tier"]
    counts = {v: sum(r["verdict"] == v for r in rows) for v in VERDICTS}
    compared = [r for r in rows if r["beats_open_loop"]]
    missing = [r["task"] for r in rows if r["learner"] and r["ppo"] is None]
    partial = [
        r["task"] for r in rows if r["ppo"] is not None and r["ppo"]["seeds"] < tier["seeds"]
    ]
    lines = [
        f"## {name.capitalize()}: {tier['budget']:,} agent-steps x {tier['seeds']} seeds",
        "",
        f"The {name} tier: {TIER_TEXT[name]}. `make benchmark TIER={name}` runs it.",
        "",
    ]
    if agg is not None:
        lines.append(
            f"Aggregate normalised IQM of PPO over the {agg['tasks']} task"
            + ("s" if agg["tasks"] != 1 else "")
            + f" it was run on: **{agg['iqm']:.3g}** "
            f"(95% interval {agg['low']:.3g} to {agg['high']:.3g}); {tier['half']} at 0.5 "
            "or above."
        )
    else:
        lines.append("PPO has not been run on any task of this tier yet.")
    lines += ["", "Verdicts: " + ", ".join(f"{n} {v}" for v, n in counts.items()) + "."]
    if compared:
        beaten = [r["task"] for r in compared if r["beats_open_loop"] != "yes"]
        lines += [
            "",
            f"PPO beats open-loop play on {len(compared) - len(beaten)} of the "
            f"{len(compared)} tasks where both have run"
            + ("; not shown on " + ", ".join(f"`{t}`" for t in beaten) + "." if beaten else "."),
        ]
    lines += [
        "",
        f"PPO's CPU time in this tier: {tier['ppo_seconds'] / 3600:.2f} CPU-hours (training "
        "and scoring, summed over seeds). " + planned_text(tier),
        "",
    ]
    if agg is not None:
        lines += [
            f"```{{image}} {figure_path(name)}",
            f":alt: PPO's normalised score per task in the {name} tier, IQM over seeds with "
            "95% intervals",
            ":width: 640px",
            "```",
            "",
        ]
    for kind, title in (("scenario", "Scenarios"), ("stream", "Streams")):
        shown = [r for r in rows if r["kind"] == kind and (r["learner"] or r["ppo"])]
        lines += [f"### {title} ({name})", ""]
        lines += table(shown, tier["seeds"]) if shown else [f"No {kind} in this tier."]
        lines.append("")
    lines += [f"### Not yet run ({name})", ""]
    if missing:
        lines.append(
            f"PPO has no committed result of this tier on these tasks yet; `make benchmark "
            f"TIER={name}` runs them: " + ", ".join(f"`{m}`" for m in missing) + "."
        )
    else:
        lines.append("Every task of this tier has its PPO results.")
    if partial:
        lines += [
            "",
            f"PPO has fewer than {tier['seeds']} seeds on "
            + ", ".join(f"`{m}`" for m in partial)
            + f"; `make benchmark TIER={name}` runs the rest.",
        ]
    if name == "certificate":
        stray = open_at_standard(summary)
        lines += [
            "",
            "Tasks below 0.5 at the standard budget that this tier does not run yet: "
            + (", ".join(f"`{t}`" for t in stray) + "." if stray else "none."),
        ]
    if any(r["runs"] for r in rows):
        lines += [
            "",
            f"### Runs ({name})",
            "",
            "Each PPO seed: its CPU time, the machine's load average before and after it, "
            "and the calibration timed at its start (256 x 256 matrix products per "
            "CPU-second of one thread: a faster machine does more).",
            "",
            *runs_table(rows),
        ]
    return [*lines, ""]


def render(summary: dict) -> str:
    tiers = summary["tiers"]
    cpu = summary["cpu_seconds"]
    search = summary["open_loop"]
    smoke = tiers["smoke"]
    lines = [
        "# Benchmark",
        "",
        "Random play, open-loop play, each task's scripted reference solver and "
        "shared-parameter PPO on every shipped scenario and task stream, PPO in tiers of "
        "budget. Written by `make benchmark-table` from the per-seed JSON files under "
        "`results/benchmark/` (no training); `make benchmark TIER=smoke|standard|certificate` "
        "runs what is missing and resumes where it stopped (`baselines/benchmark.py`, "
        "settings in `baselines/benchmark.yaml`).",
        "",
        "## How it is measured",
        "",
        f"- Random, scripted and open-loop play run {summary['seeds']} seeds on each task, and "
        "serve every tier (a scripted solver that draws no random numbers, `greedy`, "
        "`planner` or `carrier`, runs one: its seeds play alike); PPO runs its tier's seeds. "
        f"Every seed is scored on the same {summary['episodes']} held-out episodes (a "
        "scenario: reset with seeds 100000 on; a stream: each task's, seeded as "
        "`baselines.lifelong` seeds its evaluation blocks). A scenario's score is the mean "
        "return per agent its reference counts (with `carrier_vs_random`, the first team's "
        "against random play); a stream's is the mean over its tasks (the never-ending "
        "stream: its first 1000 steps).",
        "- Open-loop play (`baselines/open_loop.py`): actions by the time step alone, never "
        f"by what the agent sees. Per seed, {search['candidates']} schedules are drawn (each "
        f"action uniform, held for 1 to {search['hold']} steps; each agent its own); the one "
        f"with the best mean over {search['episodes']} training episodes (seeded apart from "
        "the held-out ones) is kept and scored on the held-out episodes. PPO that does not "
        "beat it has learnt nothing a fixed schedule of moves could not do.",
        "- PPO: `baselines.ppo` (one network shared by every agent, on the batched env) for "
        "the budget of agent-steps the table states, in the configuration it names (options "
        "in the settings file; the learner's defaults otherwise), then its final checkpoint "
        "is scored; through a stream of tasks, `baselines.lifelong --method finetune` over "
        "the stream's life scaled to the budget, scored by its last evaluation block; "
        "through the never-ending stream, the same learner for the budget "
        "(`baselines/never_ending.py`), its checkpoint then scored as the other methods are.",
        "- Tiers: " + "; ".join(f"**{t}**: {TIER_TEXT[t]}" for t in tiers) + ".",
        "- Figures: interquartile mean over seeds (95% stratified bootstrap interval). "
        "Normalised: random play 0, scripted play 1 (the means of their seeds). PPO beats "
        "open-loop play when its interval lies above open-loop play's (raw scores); **no** "
        "when it lies below, **not shown** when they overlap.",
        "- Verdicts: " + "; ".join(f"**{name}**: {text}" for name, text in VERDICTS.items()) + ".",
        "- Learning curves (each scenario's page): the training return at 50 checkpoints of "
        "each seed, IQM over seeds with its 95% interval, random, scripted and open-loop "
        "play's held-out scores as lines (`baselines/benchmark_curves.py`; "
        "`docs/images/curves/`).",
        "",
        "## Tiers",
        "",
        *markdown_table(
            ["Tier", "Budget", "Seeds", "Tasks with PPO results", "Aggregate normalised IQM"]
            + ["At 0.5 or above", "PPO CPU-hours"],
            [
                [
                    t["tier"],
                    f"{t['budget']:,}",
                    str(t["seeds"]),
                    f"{sum(r['ppo'] is not None for r in t['rows'])} of "
                    f"{sum(r['learner'] for r in t['rows'])}",
                    figure_text(t["aggregate"]) or "-",
                    str(t["half"]),
                    f"{t['ppo_seconds'] / 3600:.2f}",
                ]
                for t in tiers.values()
            ],
        ),
        "",
        f"CPU time of random, scripted and open-loop play: random {cpu['random']:.0f} s, "
        f"scripted {cpu['scripted']:.0f} s, open-loop {cpu['open_loop']:.0f} s (summed over "
        "seeds).",
        "",
        "## Random, scripted and open-loop play",
        "",
        *reference_table(smoke["rows"]),
        "",
    ]
    for tier in tiers.values():
        lines += tier_section(tier, summary)
    if summary.get("levels") is not None:
        lines += [*render_levels(summary["levels"]), ""]
    lines += [
        "## Provenance",
        "",
        "Commits the results were run at: " + ", ".join(f"`{c}`" for c in summary["commits"]),
        "",
        "Versions: "
        + "; ".join(
            ", ".join(f"{k} {v}" for k, v in json.loads(v).items()) for v in summary["versions"]
        ),
        "",
        "Each JSON file also holds the machine's load before and after its run and, from "
        "the tiers on, the calibration timed at its start.",
        "",
    ]
    return "\n".join(lines)


def draw(tier: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in tier["rows"] if r["normalised"] is not None]
    fig, ax = plt.subplots(figsize=(7, 1.2 + 0.32 * max(1, len(rows))))
    if rows:
        y = np.arange(len(rows))
        points = np.array([r["normalised"]["iqm"] for r in rows])
        lows = points - np.array([r["normalised"]["low"] for r in rows])
        highs = np.array([r["normalised"]["high"] for r in rows]) - points
        ax.errorbar(points, y, xerr=[lows, highs], fmt="o", color="tab:blue", capsize=3)
        ax.set_yticks(y, [r["task"] for r in rows])
        ax.invert_yaxis()
    else:
        ax.text(0.5, 0.5, "no PPO results yet", ha="center", va="center", transform=ax.transAxes)
        ax.set_yticks([])
    ax.axvline(0.0, color="grey", lw=1, ls=":")
    ax.axvline(1.0, color="tab:green", lw=1, ls="--")
    ax.set_xlabel(
        f"PPO ({tier['tier']}), normalised (random 0, scripted 1): IQM over seeds, 95% interval"
    )
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100, metadata={"Software": None})
    plt.close(fig)


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


def curves(root: Path, config: BenchmarkConfig, summary: dict, images: Path) -> list[Path]:
    """Each scenario's learning-curve figure, from the curves in its PPO records (every
    tier that has them); the files written."""
    written = []
    reference = summary["tiers"]["smoke"]["rows"]
    by_tier = {t: read_results(root, t) for t in summary["tiers"]}
    for row in reference:
        shown = {}
        for tier, results in by_tier.items():
            seeds = [r.get("curve") for r in results.get(row["task"], {}).get("ppo", [])]
            curve = task_curve([c for c in seeds if c])
            if curve is not None:
                shown[tier] = curve
        if not shown:
            continue
        lines = {
            m: row[m]["iqm"] for m in ("random", "scripted", "open_loop") if row[m] is not None
        }
        path = images / f"{row['task']}.png"
        draw_curves(row["task"], shown, lines, path)
        written.append(path)
    return written


def write(
    root: Path = OUT,
    config_path: str | Path = ROOT / "baselines" / "benchmark.yaml",
    levels: Path = LEVELS_OUT,
    docs: Path = ROOT / "docs",
):
    """Rebuild the page, each tier's figure, the learning curves and summary.json from the
    JSON under ``root``."""
    config = load_config(config_path)
    summary = build(root, config, levels=levels)
    docs.mkdir(parents=True, exist_ok=True)
    (docs / "benchmark.md").write_text(render(summary), encoding="utf-8")
    for tier in summary["tiers"].values():
        if tier["tier"] == "smoke" or tier["aggregate"] is not None:
            draw(tier, docs / figure_path(tier["tier"]))
    summary["curves"] = curves(root, config, summary, docs / CURVES)
    (root / "summary.json").write_text(
        json.dumps(scenario_summary(summary), indent=1) + "\n", encoding="utf-8"
    )
    return summary


def main() -> None:
    summary = write()
    rows = len(summary["tiers"]["smoke"]["rows"])
    print(f"wrote {PAGE.relative_to(ROOT)} ({rows} tasks, {len(summary['curves'])} curves)")


if __name__ == "__main__":
    main()
