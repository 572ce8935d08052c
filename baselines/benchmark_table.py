"""The benchmark's page, docs/benchmark.md, rebuilt from the committed per-seed JSON files
alone (no training): every shipped scenario and stream, random / scripted / PPO with 95%
intervals, the budget and a verdict per task, and a figure of the normalised scores.

    python -m baselines.benchmark_table          # make benchmark-table

Scores are normalised per task, random play 0 and the scripted reference 1 (the means of
their seeds); a task whose scripted play does not beat random play has no scale, and the
page says so. Each figure is the interquartile mean over seeds with a 95% stratified
bootstrap interval (``flatland_ma.evaluation.stats``, as the evaluation suites report
them); the aggregate pools the normalised PPO seeds of every task that has them.

Also written: ``results/benchmark/summary.json`` (each task's figures, which the
catalogue's scenario pages show) and ``docs/images/benchmark.png``.
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
from baselines.benchmark_config import METHODS, BenchmarkConfig, load_config
from baselines.levels import LEVELS_OUT, read_levels, render_levels
from flatland_ma.evaluation.stats import normalise, stratified_bootstrap

PAGE = ROOT / "docs" / "benchmark.md"
FIGURE = ROOT / "docs" / "images" / "benchmark.png"
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


def read_results(root: Path) -> dict[str, dict[str, list[dict]]]:
    """``{task: {method: [record of each seed, by seed]}}`` from ``root``'s JSON files;
    ``VersionMismatch`` if one task's files were made on different versions."""
    out: dict[str, dict[str, list[dict]]] = {}
    made: dict[str, dict[str, Path]] = {}
    for path in sorted(root.glob("*/*/seed_*.json")):
        record = json.loads(path.read_text(encoding="utf-8"))
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


def task_row(name: str, kind: str, methods: dict[str, list[dict]], config) -> dict:
    """One task's figures: each method's IQM and interval over seeds (raw scores), PPO's
    normalised, the verdict, the budget and the CPU seconds spent."""
    row: dict = {"task": name, "kind": kind, "budget": config.task(name).budget}
    for method in METHODS:
        records = methods.get(method, [])
        row[method] = interval([r["score"] for r in records]) if records else None
    if methods.get("ppo"):
        row["budget"] = methods["ppo"][0]["budget"]
    row["learner"] = ppo_possible(name, kind)
    row["cpu_seconds"] = sum(r["cpu_seconds"] for rs in methods.values() for r in rs)
    row["normalised"], row["scale"] = None, None
    if row["random"] and row["scripted"]:
        low = float(np.mean([r["score"] for r in methods["random"]]))
        high = float(np.mean([r["score"] for r in methods["scripted"]]))
        row["scale"] = {"random": low, "scripted": high, "ok": has_scale(low, high)}
        if row["scale"]["ok"] and row["ppo"]:
            scores = normalise([r["score"] for r in methods["ppo"]], low, high)
            row["normalised"] = interval(scores)
            row["normalised_seeds"] = [float(s) for s in scores]
    row["verdict"] = verdict(row["normalised"])
    return row


def build(root: Path, config: BenchmarkConfig, tasks=None, levels: Path | None = None) -> dict:
    """Every task's row and the aggregate over tasks, from the JSON under ``root`` (and the
    level runs under ``levels``, if given)."""
    results = read_results(root)
    tasks = tasks or list_tasks()
    for name, kind in tasks:
        _check_current(name, kind, results.get(name, {}))
    rows = [task_row(n, k, results.get(n, {}), config) for n, k in tasks]
    scored = [r["normalised_seeds"] for r in rows if r["normalised"] is not None]
    aggregate = None
    if scored:
        point, low, high = stratified_bootstrap(scored)
        aggregate = {"iqm": point, "low": low, "high": high, "tasks": len(scored)}
    records = [r for methods in results.values() for rs in methods.values() for r in rs]
    totals = {
        method: round(sum(r["cpu_seconds"] for r in records if r["method"] == method), 1)
        for method in METHODS
    }
    ppo = [r for r in records if r["method"] == "ppo"]
    planned = sum(r["budget"] * config.seeds for r in rows if r["learner"])
    rate = sum(r["agent_steps"] for r in ppo) / max(1e-9, sum(r["cpu_seconds"] for r in ppo))
    return {
        "rows": rows,
        "planned_steps": planned,
        "ppo_rate": round(rate, 1) if ppo else None,
        "aggregate": aggregate,
        "cpu_seconds": totals,
        "commits": sorted({r["commit"] for r in records}),
        "versions": sorted({json.dumps(r["versions"], sort_keys=True) for r in records}),
        "seeds": config.seeds,
        "options": dict(config.default.ppo),
        "episodes": config.episodes,
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
    return f"{x['iqm']:.3g} ({x['low']:.3g} to {x['high']:.3g})"


def ppo_cell(row: dict, seeds: int) -> str:
    if row["ppo"] is not None:
        done = row["ppo"]["seeds"]
        return figure_text(row["ppo"]) + (f", {done} of {seeds} seeds" if done < seeds else "")
    return "not yet run" if row["learner"] else "no learner for it"


def normalised_cell(row: dict) -> str:
    if row["normalised"] is not None:
        return figure_text(row["normalised"])
    if row["scale"] is not None and not row["scale"]["ok"]:
        return "no scale: scripted does not beat random"
    return ""


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


def table(rows: list[dict], seeds: int) -> list[str]:
    headers = ["Task", "Random", "Scripted", "Reference solver", "PPO", "PPO, normalised"]
    headers += ["Budget", "Verdict"]
    out = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    for r in rows:
        budget = f"{r['budget']:,}" if r["learner"] else "-"
        cells = [
            f"`{r['task']}`",
            figure_text(r["random"]) or "not yet run",
            figure_text(r["scripted"]) or "not yet run",
            solver_text(r["task"], r["kind"]),
            ppo_cell(r, seeds),
            normalised_cell(r),
            budget,
            r["verdict"],
        ]
        out.append("| " + " | ".join(cells) + " |")
    return out


def planned_text(summary: dict) -> str:
    text = (
        f"The whole PPO benchmark is {summary['planned_steps'] / 1e6:.3g}M agent-steps of "
        "training (every budget times the seeds)"
    )
    rate = summary["ppo_rate"]
    if not rate:
        return text + "."
    hours = summary["planned_steps"] / rate / 3600
    return (
        text + f"; at the {rate:.0f} agent-steps per CPU-second the committed PPO seeds "
        f"averaged (training and scoring), about {hours:.1f} CPU-hours."
    )


def render(summary: dict, figure: str = "images/benchmark.png") -> str:
    rows = summary["rows"]
    cpu = summary["cpu_seconds"]
    agg = summary["aggregate"]
    counts = {v: sum(r["verdict"] == v for r in rows) for v in VERDICTS}
    missing = [r["task"] for r in rows if r["learner"] and r["ppo"] is None]
    partial = [
        r["task"] for r in rows if r["ppo"] is not None and r["ppo"]["seeds"] < summary["seeds"]
    ]
    lines = [
        "# Benchmark",
        "",
        "Random play, each task's scripted reference solver and shared-parameter PPO on every "
        "shipped scenario and task stream. Written by `make benchmark-table` from the per-seed "
        "JSON files under `results/benchmark/` (no training); `make benchmark` runs what is "
        "missing and resumes where it stopped (`baselines/benchmark.py`, settings in "
        "`baselines/benchmark.yaml`).",
        "",
        "## How it is measured",
        "",
        f"- Every method plays each task for {summary['seeds']} seeds (a scripted solver that "
        "draws no random numbers, `greedy`, `planner` or `carrier`, for one: its seeds play "
        "alike); every seed is scored on "
        f"the same {summary['episodes']} held-out episodes (a scenario: reset with seeds "
        "100000 on; a stream: each task's, seeded as `baselines.lifelong` seeds its "
        "evaluation blocks). A scenario's score is the mean return per agent its reference "
        "counts (with `carrier_vs_random`, the first team's against random play); a stream's "
        "is the mean over its tasks (the never-ending stream: its first 1000 steps).",
        "- PPO: `baselines.ppo` (one network shared by every agent, on the batched env) for "
        "the budget of agent-steps the table states, then its final checkpoint is scored; "
        "through a stream of tasks, `baselines.lifelong --method finetune` over the stream's "
        "life scaled to the budget, scored by its last evaluation block; through the "
        "never-ending stream, the same learner for the budget (`baselines/never_ending.py`), "
        "its checkpoint then scored as random and scripted play are. Options: "
        + (", ".join(f"`{k}={v}`" for k, v in summary["options"].items()) or "none")
        + ", the learner's defaults otherwise (a task's own, if any, in the settings file).",
        "- Figures: interquartile mean over seeds (95% stratified bootstrap interval). "
        "Normalised: random play 0, scripted play 1 (the means of their seeds).",
        "- Verdicts: " + "; ".join(f"**{name}**: {text}" for name, text in VERDICTS.items()) + ".",
        "",
        "## Summary",
        "",
    ]
    if agg is not None:
        lines.append(
            f"Aggregate normalised IQM of PPO over the {agg['tasks']} task"
            + ("s" if agg["tasks"] != 1 else "")
            + f" it was run on: **{agg['iqm']:.3g}** "
            f"(95% interval {agg['low']:.3g} to {agg['high']:.3g})."
        )
    else:
        lines.append("PPO has not been run on any task yet.")
    lines += [
        "",
        "Verdicts: " + ", ".join(f"{n} {name}" for name, n in counts.items()) + ".",
        "",
        f"CPU time of the committed results: {sum(cpu.values()) / 3600:.2f} CPU-hours "
        f"(random {cpu['random']:.0f} s, scripted {cpu['scripted']:.0f} s, "
        f"PPO {cpu['ppo']:.0f} s: training and scoring, summed over seeds).",
        "",
        planned_text(summary),
        "",
        f"```{{image}} {figure}",
        ":alt: PPO's normalised score per task, IQM over seeds with 95% intervals",
        ":width: 640px",
        "```",
        "",
        "## Scenarios",
        "",
        *table([r for r in rows if r["kind"] == "scenario"], summary["seeds"]),
        "",
        "## Streams",
        "",
        *table([r for r in rows if r["kind"] == "stream"], summary["seeds"]),
        "",
        "## Not yet run",
        "",
    ]
    if missing:
        lines.append(
            "PPO has no committed result on these tasks yet; `make benchmark` runs them: "
            + ", ".join(f"`{m}`" for m in missing)
            + "."
        )
    else:
        lines.append("Every task with a learner has its PPO results.")
    if partial:
        lines += [
            "",
            f"PPO has fewer than {summary['seeds']} seeds on "
            + ", ".join(f"`{m}`" for m in partial)
            + "; `make benchmark` runs the rest.",
        ]
    if summary.get("levels") is not None:
        lines += ["", *render_levels(summary["levels"])]
    lines += [
        "",
        "## Provenance",
        "",
        "Commits the results were run at: " + ", ".join(f"`{c}`" for c in summary["commits"]),
        "",
        "Versions: "
        + "; ".join(
            ", ".join(f"{k} {v}" for k, v in json.loads(v).items()) for v in summary["versions"]
        ),
        "",
        "Each JSON file also holds the machine's load before and after its run.",
        "",
    ]
    return "\n".join(lines)


def draw(summary: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in summary["rows"] if r["normalised"] is not None]
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
    ax.set_xlabel("PPO, normalised (random 0, scripted 1): IQM over seeds, 95% interval")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100, metadata={"Software": None})
    plt.close(fig)


def scenario_summary(summary: dict) -> dict:
    """Each task's figures, for the catalogue's pages (``results/benchmark/summary.json``)."""
    keep = ("kind", "budget", "random", "scripted", "ppo", "normalised", "verdict", "learner")
    return {r["task"]: {k: r[k] for k in keep} for r in summary["rows"]}


def write(
    root: Path = OUT,
    config_path: str | Path = ROOT / "baselines" / "benchmark.yaml",
    levels: Path = LEVELS_OUT,
):
    """Rebuild the page, the figure and summary.json from the JSON under ``root``."""
    summary = build(root, load_config(config_path), levels=levels)
    PAGE.write_text(render(summary), encoding="utf-8")
    draw(summary, FIGURE)
    (root / "summary.json").write_text(
        json.dumps(scenario_summary(summary), indent=1) + "\n", encoding="utf-8"
    )
    return summary


def main() -> None:
    summary = write()
    print(f"wrote {PAGE.relative_to(ROOT)} ({len(summary['rows'])} tasks)")


if __name__ == "__main__":
    main()
