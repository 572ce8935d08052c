"""Reading a lifelong run folder, and its table, JSON and task-by-time picture.

The folder (as ``baselines/lifelong.py`` writes it)::

    RUN_DIR/stream.json                       tasks, segments [[task, start, end], ...],
                                              random (mean return of random play per task)
    RUN_DIR/<method>/seed_<k>/evaluations.csv step,task,episodes,mean_return: every block
                                              evaluates every task
    RUN_DIR/reference/seed_<k>/evaluations.csv the same, for a learner on each task alone
                                              (step counted within its own training)

Every fault is reported with the file and the line.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flatland_ma.lifelong.metrics import interval, life_metrics, normalise

REFERENCE = "reference"
COLUMNS = ["step", "task", "episodes", "mean_return"]


class RunError(ValueError):
    """A run folder that cannot be read; the message names the file and line."""


@dataclass
class Learner:
    """One method's lives: ``returns[seed][b, i]`` at ``steps[seed][b]``."""

    seeds: list[int] = field(default_factory=list)
    steps: list[np.ndarray] = field(default_factory=list)
    returns: list[np.ndarray] = field(default_factory=list)


@dataclass
class Run:
    stream: str
    tasks: list[str]
    segments: list[tuple[int, int, int]]
    random: np.ndarray
    learners: dict[str, Learner]
    reference: dict[int, list[tuple[np.ndarray, np.ndarray]]]
    """Per seed, per task: the reference learner's (steps, returns)."""


def load_run(folder: str | Path) -> Run:
    folder = Path(folder)
    path = folder / "stream.json"
    try:
        meta = json.loads(path.read_text())
        tasks = [str(t) for t in meta["tasks"]]
        segments = [(int(t), int(a), int(b)) for t, a, b in meta["segments"]]
        random = np.array(meta["random"], float)
    except FileNotFoundError:
        raise RunError(f"{path}: no such file (is {folder} a lifelong run folder?)") from None
    except (ValueError, KeyError, TypeError) as err:
        raise RunError(f"{path}: not a stream summary ({type(err).__name__}: {err})") from None
    if len(random) != len(tasks) or any(not 0 <= t < len(tasks) for t, _, _ in segments):
        raise RunError(f"{path}: random or segments do not match the {len(tasks)} tasks")
    learners: dict[str, Learner] = {}
    reference: dict[int, list] = {}
    for method in sorted(p for p in folder.iterdir() if p.is_dir()):
        for seed_dir in sorted(method.glob("seed_*")):
            csv_path = seed_dir / "evaluations.csv"
            if not csv_path.is_file():
                continue
            seed = int(seed_dir.name.split("_", 1)[1])
            rows = _rows(csv_path, len(tasks))
            if method.name == REFERENCE:
                reference[seed] = [_curve(rows, i, csv_path) for i in range(len(tasks))]
            else:
                steps, returns = _blocks(rows, len(tasks), csv_path)
                learner = learners.setdefault(method.name, Learner())
                learner.seeds.append(seed)
                learner.steps.append(steps)
                learner.returns.append(returns)
    return Run(str(meta.get("stream", folder.name)), tasks, segments, random, learners, reference)


def _rows(path: Path, tasks: int) -> list[tuple[int, int, float]]:
    out = []
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header != COLUMNS:
            raise RunError(f"{path}:1: expected the columns {','.join(COLUMNS)}, got {header}")
        for line, row in enumerate(reader, start=2):
            try:
                step, task, _, value = int(row[0]), int(row[1]), int(row[2]), float(row[3])
            except (ValueError, IndexError):
                raise RunError(
                    f"{path}:{line}: expected step,task,episodes,mean_return: {row}"
                ) from None
            if not 0 <= task < tasks or not math.isfinite(value):
                raise RunError(f"{path}:{line}: task {task} of {tasks}, return {value}")
            out.append((step, task, value))
    if not out:
        raise RunError(f"{path}: no evaluations")
    return out


def _blocks(rows, tasks: int, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Rows in blocks of every task, in order."""
    if len(rows) % tasks:
        raise RunError(f"{path}: {len(rows)} rows are not whole blocks of {tasks} tasks")
    steps, returns = [], []
    for b in range(len(rows) // tasks):
        block = rows[b * tasks : (b + 1) * tasks]
        if sorted(r[1] for r in block) != list(range(tasks)) or len({r[0] for r in block}) != 1:
            raise RunError(f"{path}:{b * tasks + 2}: block {b} does not evaluate every task once")
        steps.append(block[0][0])
        returns.append([r[2] for r in sorted(block, key=lambda r: r[1])])
    return np.array(steps, float), np.array(returns, float)


def _curve(rows, task: int, path: Path) -> tuple[np.ndarray, np.ndarray]:
    mine = [(s, v) for s, t, v in rows if t == task]
    if not mine:
        raise RunError(f"{path}: the reference never evaluates task {task}")
    return np.array([s for s, _ in mine], float), np.array([v for _, v in mine], float)


# -- the numbers ------------------------------------------------------------------------


def reference_level(run: Run) -> np.ndarray:
    """Per task, the reference learner's final return averaged over its seeds (the score
    1); where it does not beat random play, the best mean return any learner reached."""
    tasks = len(run.tasks)
    if not run.reference:
        raise RunError("no reference learner in the run: forward transfer and the scale need it")
    level = np.array([np.mean([r[i][1][-1] for r in run.reference.values()]) for i in range(tasks)])
    for i in np.flatnonzero(level <= run.random):
        best = [ret[:, i].max() for lr in run.learners.values() for ret in lr.returns]
        level[i] = max(best + [run.random[i] + 1.0])
    return level


def summarise(run: Run) -> dict:
    """Every metric per method, per seed and as mean [95% t-interval] over seeds."""
    level = reference_level(run)
    out: dict = {"stream": run.stream, "tasks": run.tasks, "random": run.random.tolist()}
    out["reference_final_return"] = level.tolist()
    out["methods"] = {}
    for name, learner in run.learners.items():
        per_seed = []
        for seed, steps, returns in zip(learner.seeds, learner.steps, learner.returns):
            p = normalise(returns, run.random, level)
            ref = run.reference.get(seed) or next(iter(run.reference.values()))
            ref_p = [(s, normalise(v, run.random[i], level[i])) for i, (s, v) in enumerate(ref)]
            m = life_metrics(steps, p, run.segments, ref_p)
            per_seed.append(
                {
                    "seed": seed,
                    "average": m.average,
                    "forgetting": _listed(m.forgetting),
                    "forward_transfer": _listed(m.forward_transfer),
                    "backward_transfer": m.backward_transfer,
                    "final": p[-1].tolist(),
                }
            )
        aggregate = {
            "average": interval([s["average"] for s in per_seed]),
            "forgetting": interval([_nanmean(s["forgetting"]) for s in per_seed]),
            "forward_transfer": interval([_nanmean(s["forward_transfer"]) for s in per_seed]),
            "backward_transfer": interval([s["backward_transfer"] for s in per_seed]),
            "forgetting_per_task": [
                interval([s["forgetting"][i] for s in per_seed]) for i in range(len(run.tasks))
            ],
            "forward_transfer_per_task": [
                interval([s["forward_transfer"][i] for s in per_seed])
                for i in range(len(run.tasks))
            ],
        }
        out["methods"][name] = {"seeds": per_seed, "aggregate": aggregate}
    return out


def _listed(values: np.ndarray) -> list:
    return [None if np.isnan(v) else float(v) for v in values]


def _nanmean(values: list) -> float:
    kept = [v for v in values if v is not None]
    return float(np.mean(kept)) if kept else float("nan")


def _cell(triple) -> str:
    mean, low, high = triple
    if math.isnan(mean):
        return "-"
    return f"{mean:.2f}" if math.isnan(low) else f"{mean:.2f} [{low:.2f}, {high:.2f}]"


def table(summary: dict) -> str:
    """The metrics as text: one row per method, then per task."""
    heads = ["average", "forgetting", "forward_transfer", "backward_transfer"]
    lines = [f"stream {summary['stream']}: normalised (random 0, the reference learner alone 1)"]
    lines.append(f"{'method':<12}" + "".join(f"{h:>28}" for h in heads))
    for name, data in summary["methods"].items():
        agg = data["aggregate"]
        n = len(data["seeds"])
        lines.append(f"{name + f' ({n})':<12}" + "".join(f"{_cell(agg[h]):>28}" for h in heads))
    lines.append("")
    lines.append(
        f"{'task':<12}{'random':>10}{'reference':>11}"
        + "".join(f"{m + ' F':>26}{m + ' FT':>26}" for m in summary["methods"])
    )
    for i, task in enumerate(summary["tasks"]):
        cells = "".join(
            f"{_cell(d['aggregate']['forgetting_per_task'][i]):>26}"
            f"{_cell(d['aggregate']['forward_transfer_per_task'][i]):>26}"
            for d in summary["methods"].values()
        )
        lines.append(
            f"{task:<12}{summary['random'][i]:>10.1f}{summary['reference_final_return'][i]:>11.1f}{cells}"
        )
    return "\n".join(lines)


def plot(run: Run, summary: dict, path: Path) -> Path:
    """The task-by-time performance matrix, one panel per method (mean over seeds)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    level = np.array(summary["reference_final_return"])
    names = list(run.learners)
    fig, axes = plt.subplots(
        len(names),
        1,
        figsize=(9, 1.2 + 0.45 * len(run.tasks) * len(names) + 0.6 * len(names)),
        squeeze=False,
    )
    image = None
    for ax, name in zip(axes[:, 0], names):
        learner = run.learners[name]
        blocks = min(len(s) for s in learner.steps)
        p = np.mean([normalise(r[:blocks], run.random, level) for r in learner.returns], axis=0)
        steps = np.mean([s[:blocks] for s in learner.steps], axis=0)
        edges = np.concatenate([[steps[0]], (steps[1:] + steps[:-1]) / 2, [steps[-1]]])
        image = ax.pcolormesh(
            edges, np.arange(len(run.tasks) + 1), p.T, cmap="viridis", vmin=-0.5, vmax=1.5
        )
        for task, start, end in run.segments:
            ax.axvline(start, color="white", lw=0.8)
            ax.text(
                (start + end) / 2,
                len(run.tasks) + 0.1,
                run.tasks[task],
                ha="center",
                va="bottom",
                fontsize=7,
            )
        ax.set_yticks(np.arange(len(run.tasks)) + 0.5, run.tasks, fontsize=8)
        ax.set_title(f"{name} ({len(learner.seeds)} seeds)", fontsize=9, pad=16)
    axes[-1, 0].set_xlabel("agent-steps of the life")
    fig.subplots_adjust(hspace=0.55)
    if image is not None:
        fig.colorbar(image, ax=axes[:, 0].tolist(), label="normalised performance")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path
