"""The benchmark's levels: runs of a shipped learner held to a stated level, seed by seed,
each summarised in a small JSON file under ``results/levels/<level>/`` that the benchmark
page (``baselines.benchmark.table``) shows with the level's verdict.

A record is taken from a finished ``baselines.ppo`` run, its CSV log and the JSON and
checkpoint written beside it:

    python -m baselines.benchmark.levels fruits_poisons_300 runs/ppo/fp_preset/seed_1.csv
    python -m baselines.benchmark.levels coop_carry_half runs/coop/coop_carry_s0.csv

It holds the run's options, agent-steps, wall and CPU time and the load, the mean return
per agent of its last 50 episodes (and the wall time and agent-step at which a mean of 50
first reached the level's return, for a return level), and for a level on the held-out
episodes the final checkpoint's score on the benchmark's held-out episodes, normalised by
the benchmark's random and scripted scores.
"""

from __future__ import annotations

import argparse
import csv
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from baselines.benchmark.play import play_task
from baselines.benchmark.records import OUT, read_results, write_record
from baselines.benchmark.settings import ROOT, SETTINGS, load_config
from flatland_ma.evaluation.stats import normalise
from flatland_ma.policies.checkpoint import SUFFIX

LEVELS_OUT = ROOT / "results" / "levels"
WINDOW = 50
"""Episodes in the moving mean a return level is read from."""


@dataclass(frozen=True)
class Level:
    task: str
    text: str
    """The level, as the page states it."""
    measure: Literal["last_50", "held_out"]
    """``last_50``: the mean return per agent of the run's last 50 episodes;
    ``held_out``: the final checkpoint's normalised score on the held-out episodes."""
    target: float
    seeds: int
    """Seeds that must each meet it."""
    seconds: float | None = None
    """Wall time within which each seed's run must end (None: no limit)."""


HALF = "at least half of the scripted score (normalised 0.5) on the benchmark's held-out "
HALF += "episodes, in 3 seeds out of 3"
LEVELS = {
    "fruits_poisons_300": Level(
        "fruits_poisons",
        "The paper's single-agent level: the last 50 episodes average at least 300, in "
        "every one of 5 seeds, each run within 10 minutes on this machine.",
        "last_50",
        300.0,
        5,
        600.0,
    ),
    "coop_carry_half": Level("coop_carry", f"`coop_carry`: {HALF}.", "held_out", 0.5, 3),
    "plate_relay_half": Level("plate_relay", f"`plate_relay`: {HALF}.", "held_out", 0.5, 3),
    "signal_maps_half": Level(
        "signal_maps",
        f"`signal_maps` (the guide is paid when the seeker scores): {HALF}.",
        "held_out",
        0.5,
        3,
    ),  # fmt: skip
}


def moving_means(csv_path: Path) -> tuple[list[dict], np.ndarray]:
    """The log's rows, and after each row the mean return per agent over the last
    ``WINDOW`` episodes (rows of the log: one per agent and episode)."""
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{csv_path}: no episode in the log")
    agents = len({row["agent"] for row in rows})
    returns = np.array([float(row["return"]) for row in rows])
    n = WINDOW * agents
    sums = np.cumsum(np.concatenate([[0.0], returns]))
    counts = np.minimum(np.arange(1, len(returns) + 1), n)
    means = (sums[1:] - sums[np.maximum(np.arange(1, len(returns) + 1) - n, 0)]) / counts
    return rows, means


def summarise(csv_path: Path, target: float | None = None) -> dict:
    """A run's figures from its log and the JSON beside it."""
    rows, means = moving_means(csv_path)
    run = json.loads(csv_path.with_suffix(".json").read_text())
    agents = len({row["agent"] for row in rows})
    full = means[min(len(means), WINDOW * agents) - 1 :]
    out = {
        "scenario": run["args"]["scenario"],
        "seed": run["args"]["seed"],
        "options": {k: v for k, v in run["args"].items() if k not in ("csv", "seed")},
        "agent_steps": run["steps"],
        "episodes": len(rows) // agents,
        "wall_seconds": run["wall_seconds"],
        "cpu_seconds": run.get("cpu_seconds"),
        "load_average": [run.get("load_average_start"), run.get("load_average_end")],
        "calibration": run.get("calibration_matmuls_per_second"),
        "last_50": round(float(means[-1]), 6),
        "best_50": round(float(full.max()), 6),
    }
    if target is not None:
        start = min(len(means), WINDOW * agents) - 1
        reached = np.flatnonzero(means[start:] >= target)
        first = rows[start + reached[0]] if len(reached) else None
        out["first_at_step"] = int(first["step"]) if first else None
        out["first_at_wall"] = float(first["wall_time"]) if first else None
    return out


def held_out(task: str, seed: int, checkpoint: Path) -> dict:
    """The checkpoint's score on the benchmark's held-out episodes, and normalised by the
    benchmark's committed random and scripted scores of the task."""
    config = load_config(SETTINGS)
    score, episodes, _ = play_task(task, "scenario", "ppo", seed, config, str(checkpoint))
    methods = read_results(OUT)[task]
    low = float(np.mean([r["score"] for r in methods["random"]]))
    high = float(np.mean([r["score"] for r in methods["scripted"]]))
    return {
        "held_out": round(score, 6),
        "held_out_episodes": [round(e, 6) for e in episodes],
        "normalised": round(float(normalise(score, low, high)), 6) + 0.0,  # no -0.0
    }


def record(name: str, csv_path: Path, out: Path = LEVELS_OUT, tag: str = "ppo") -> Path:
    """Summarise the run logged at ``csv_path`` for level ``name``, as a seed of the runs
    called ``tag`` (runs of one tag share their options); the file written."""
    level = LEVELS[name]
    return_level = level.measure == "last_50"
    figures = summarise(csv_path, level.target if return_level else None)
    if figures["scenario"] != level.task:
        raise ValueError(f"{csv_path}: a run of {figures['scenario']!r}, not {level.task!r}")
    if not return_level:
        figures.update(held_out(level.task, figures["seed"], csv_path.with_suffix(SUFFIX)))
    value = figures["last_50"] if return_level else figures["normalised"]
    in_time = level.seconds is None or figures["wall_seconds"] <= level.seconds
    figures["met"] = bool(value >= level.target and in_time)
    path = out / name / f"{tag}_seed_{figures['seed']}.json"
    write_record(path, {"level": name, "tag": tag, "run": str(csv_path), **figures})
    return path


def read_levels(root: Path = LEVELS_OUT) -> dict[str, list[dict]]:
    """``{level: [record of each run, by tag and seed]}``."""
    found: dict[str, list[dict]] = {}
    for path in sorted(root.glob("*/*_seed_*.json")):
        data = json.loads(path.read_text(encoding="utf-8"))
        found.setdefault(data["level"], []).append(data)
    for records in found.values():
        records.sort(key=lambda r: (r["tag"], r["seed"]))
    return found


SHOWN = (
    "preset",
    "num_envs",
    "torch_threads",
    "overlap",
    "use_depth",
    "memory",
    "frames",
    "team_reward",
    "shaping",
    "shaping_potential",
    "shaping_gamma",
    "curriculum",
)
"""The run options the page names (beside the task's defaults)."""
QUIET = {"memory": "none", "frames": 1, "shaping_potential": "auto", "shaping_gamma": -1.0}
"""Values of those options that are their defaults, named on no page."""


def _options(options: dict) -> str:
    shown = []
    for key in SHOWN:
        value = options.get(key)
        if value not in (None, "", False, 0, 0.0) and value != QUIET.get(key):
            shown.append(f"`{key}` {Path(value).name if key == 'curriculum' else value}")
    return ", ".join(shown) or "defaults"


def _calibration(figures: list[float] | None) -> str:
    """The machine's speed at the run's start and end (``baselines.common.calibration``:
    256 x 256 matrix products per CPU-second), or "-" for a run that did not record it."""
    return "-" if not figures else "-".join(f"{x:,.0f}" for x in figures)


def _minutes(seconds: float | None) -> str:
    return "-" if seconds is None else f"{seconds / 60:.1f} min"


def render_levels(found: dict[str, list[dict]]) -> list[str]:
    """The page's section: each level, its runs seed by seed, and its verdict."""
    lines = [
        "## Levels",
        "",
        "Runs of a shipped learner held to a level, one JSON file per seed under "
        "`results/levels/` (`python -m baselines.benchmark.levels LEVEL LOG`, from a finished "
        "`baselines.ppo` run). Load: the load average at the run's start and end. "
        "Calibration: the machine's speed at the run's start and end, 256 x 256 matrix "
        "products per CPU-second (runs before 2026-11-27 did not record it). "
        "What was tried on each open level and what blocks it: "
        "[Learning options for the open tasks](results.md#learning-options-for-the-open-tasks).",
    ]
    for name, level in LEVELS.items():
        records = found.get(name, [])
        by_tag: dict[str, list[dict]] = {}
        for r in records:
            by_tag.setdefault(r["tag"], []).append(r)
        met = max((sum(r["met"] for r in rs) for rs in by_tag.values()), default=0)
        verdict = "**met**" if met >= level.seeds else "**not met**"
        lines += ["", f"### `{name}`", "", level.text, ""]
        if not records:
            lines.append(f"{verdict}: no run recorded.")
            continue
        return_level = level.measure == "last_50"
        header = (
            "| runs | seed | options | agent-steps | wall | CPU | load | calibration "
            "| last 50 | best 50 |"
        )
        header += (
            f" mean of 50 first >= {level.target:g} at |"
            if return_level
            else " held-out score | normalised |"
        )
        lines += [header + " met |", "|" + "---|" * header.count("|")]
        lines += [_row(r, return_level) for r in records]
        runs = f"{len(records)} run" + ("s" if len(records) != 1 else "")
        lines += [
            "",
            f"{verdict}: at best {met} of the {level.seeds} seeds it asks for, among runs of "
            f"one setting ({runs} recorded).",
        ]
    return lines


def _row(r: dict, return_level: bool) -> str:
    """One run's line of a level's table."""
    load = "-".join(f"{x[0]:.1f}" for x in r["load_average"] if x) or "-"
    cells = [
        f"`{r['tag']}`",
        str(r["seed"]),
        _options(r["options"]),
        f"{r['agent_steps']:,}",
        _minutes(r["wall_seconds"]),
        _minutes(r["cpu_seconds"]),
        load,
        _calibration(r.get("calibration")),
        f"{r['last_50']:.1f}",
        f"{r['best_50']:.1f}",
    ]
    if return_level:
        at = r["first_at_wall"]
        cells.append("never" if at is None else f"{_minutes(at)} ({r['first_at_step']:,})")
    else:
        cells += [f"{r['held_out']:.2f}", f"{r['normalised']:.2f}"]
    cells.append("yes" if r["met"] else "no")
    return "| " + " | ".join(cells) + " |"


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("level", choices=sorted(LEVELS))
    parser.add_argument("logs", type=Path, nargs="+", help="the runs' CSV logs")
    parser.add_argument("--tag", default="ppo", help="a name for these runs' settings")
    args = parser.parse_args()
    for log in args.logs:
        print(record(args.level, log, tag=args.tag))


if __name__ == "__main__":
    main()
