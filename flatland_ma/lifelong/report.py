"""Reading a lifelong run folder, and its table, JSON and task-by-time picture.

The folder (as ``baselines/lifelong.py`` writes it)::

    RUN_DIR/stream.json                       tasks, segments [[task, start, end], ...],
                                              random (mean return of random play per task),
                                              eval_every, eval_episodes (strict JSON)
    RUN_DIR/<method>/seed_<k>/evaluations.csv step,task,episodes,mean_return: every block
                                              evaluates every task, steps going forward
    RUN_DIR/reference/seed_<k>/evaluations.csv the same, for a learner on each task alone
                                              (step counted within its own training)

A run folder is read as scenario files are: each file through the one door
(``flatland_ma.scenario.files``: a regular file, within a size limit, UTF-8), ``stream.json``
as strict JSON into a strict spec, every number finite and plausible (``MAX_RETURN``,
``MAX_LIFE``). Every fault is a ``RunError`` naming the file, and the line and key where
it has them.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

import numpy as np
from pydantic import Field, ValidationError, model_validator

from flatland_ma.lifelong.metrics import interval, life_metrics, normalise
from flatland_ma.lifelong.streams import MAX_CYCLES, MAX_STEPS, MAX_TASKS, Label
from flatland_ma.scenario.errors import Marks, Problem, ScenarioError, SpecError
from flatland_ma.scenario.files import read_text
from flatland_ma.scenario.json_reader import parse_json
from flatland_ma.scenario.messages import problems_from
from flatland_ma.scenario.types import Spec

REFERENCE = "reference"
COLUMNS = ["step", "task", "episodes", "mean_return"]
MAX_LIFE = MAX_STEPS * MAX_TASKS * MAX_CYCLES
"""The latest agent-step of a life: every task of the longest stream, every cycle."""
MAX_RETURN = 1e12
"""The largest mean return (either sign) believed: a million per item (the scenario
format's largest reward) for a million steps. Beyond it a number is a fault of the file."""
MAX_EPISODES = 1_000_000
"""The most episodes one evaluation row may average."""
MAX_CSV_BYTES = 64 * 2**20
"""The largest evaluation table read (a million rows are about 25 MiB)."""
_FIELD = re.compile(r"[+-]?[0-9][0-9_.eE+-]{0,39}")
"""What a number in an evaluation table may look like (at most 40 characters)."""
_SEED = re.compile(r"seed_([0-9]{1,9})")

Return = Annotated[float, Field(strict=True, ge=-MAX_RETURN, le=MAX_RETURN, allow_inf_nan=False)]
Step = Annotated[int, Field(strict=True, ge=0, le=MAX_LIFE)]
TaskIndex = Annotated[int, Field(strict=True, ge=0, lt=MAX_TASKS)]


class RunError(ValueError):
    """A run folder that cannot be read; the message names the file and line."""


class StreamSummary(Spec):
    """``stream.json``: what the report needs to know of the stream the run lived."""

    stream: Annotated[str, Field(strict=True, max_length=200)] = ""
    """The stream's name."""
    tasks: Annotated[tuple[Label, ...], Field(min_length=1, max_length=MAX_TASKS)]
    """The tasks' labels, in the stream's order."""
    segments: Annotated[
        tuple[tuple[TaskIndex, Step, Step], ...],
        Field(min_length=1, max_length=MAX_TASKS * MAX_CYCLES),
    ]
    """The life, in order: [task, first agent-step, end agent-step (exclusive)]."""
    random: tuple[Return, ...]
    """Random play's mean return on each task."""
    eval_every: Annotated[int, Field(strict=True, ge=1, le=MAX_STEPS)] | None = None
    eval_episodes: Annotated[int, Field(strict=True, ge=1, le=MAX_EPISODES)] | None = None

    @model_validator(mode="after")
    def _consistent(self):
        tasks = len(self.tasks)
        if len(self.random) != tasks:
            raise SpecError(("random",), f"{len(self.random)} returns for {tasks} tasks")
        previous = 0
        for k, (task, start, end) in enumerate(self.segments):
            if task >= tasks:
                raise SpecError(("segments", k, 0), f"task {task}, of {tasks} tasks")
            if not previous <= start < end:
                raise SpecError(
                    ("segments", k),
                    f"[{start}, {end}) after a segment ending at {previous}: a segment "
                    "starts where the last one ended, and ends after it starts",
                )
            previous = end
        return self


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


def _text(path: Path, limit: int | None = None) -> str:
    """The file's text through the one door; its faults as a ``RunError``."""
    try:
        return read_text(path) if limit is None else read_text(path, limit)
    except ScenarioError as err:
        raise RunError(str(err)) from None


def read_summary(path: Path) -> StreamSummary:
    """``stream.json`` as a ``StreamSummary``; ``RunError`` (file, line, key) if it is not."""
    if not os.path.lexists(path):
        raise RunError(f"{path}: no such file (is {path.parent} a lifelong run folder?)")
    source = str(path)
    marks: Marks = {}
    try:
        raw = parse_json(_text(path), source, marks)
        if not isinstance(raw, dict):
            raise ScenarioError([Problem(source, 1, (), "expected an object of keys")])
        try:
            return StreamSummary.model_validate(raw)
        except ValidationError as err:
            problems = problems_from(err.errors(), StreamSummary, raw, marks, source)
            raise ScenarioError(problems) from None
    except ScenarioError as err:
        raise RunError(str(err)) from None


def load_run(folder: str | Path) -> Run:
    """The run folder ``folder``, every file checked; ``RunError`` naming the file, line
    and key of the first fault."""
    folder = Path(folder)
    meta = read_summary(folder / "stream.json")
    tasks = len(meta.tasks)
    learners: dict[str, Learner] = {}
    reference: dict[int, list] = {}
    for method in sorted(p for p in folder.iterdir() if p.is_dir()):
        for seed_dir in sorted(method.glob("seed_*")):
            csv_path = seed_dir / "evaluations.csv"
            if not os.path.lexists(csv_path):
                continue  # a seed folder without evaluations yet
            match = _SEED.fullmatch(seed_dir.name)
            if match is None:
                raise RunError(f"{seed_dir}: a seed's folder is named seed_<number>")
            seed = int(match.group(1))
            rows = _rows(csv_path, tasks)
            if method.name == REFERENCE:
                reference[seed] = [_curve(rows, i, csv_path) for i in range(tasks)]
            else:
                steps, returns = _blocks(rows, tasks, csv_path)
                learner = learners.setdefault(method.name, Learner())
                learner.seeds.append(seed)
                learner.steps.append(steps)
                learner.returns.append(returns)
    segments = [(int(t), int(a), int(b)) for t, a, b in meta.segments]
    random = np.array(meta.random, float)
    return Run(meta.stream or folder.name, list(meta.tasks), segments, random, learners, reference)


Row = tuple[int, int, float, int]
"""step, task, mean return, and the row's line in its file."""


def _rows(path: Path, tasks: int) -> list[Row]:
    lines = _text(path, MAX_CSV_BYTES).split("\n")
    header = lines[0].rstrip("\r").split(",")
    if header != COLUMNS:
        shown = lines[0][:80] + ("..." if len(lines[0]) > 80 else "")
        raise RunError(f"{path}:1: expected the columns {','.join(COLUMNS)}, got {shown!r}")
    out = []
    for line, text in enumerate(lines[1:], start=2):
        text = text.rstrip("\r")
        if not text:
            continue
        step, task, episodes, value = _row(text, path, line)
        where = f"{path}:{line}"
        if not 0 <= step <= MAX_LIFE:
            raise RunError(f"{where}: step {step}: not an agent-step of a life (0 to {MAX_LIFE})")
        if not 0 <= task < tasks:
            raise RunError(f"{where}: task {task} of {tasks}")
        if not 1 <= episodes <= MAX_EPISODES:
            raise RunError(f"{where}: {episodes} episodes (1 to {MAX_EPISODES})")
        if not (math.isfinite(value) and abs(value) <= MAX_RETURN):
            raise RunError(f"{where}: return {value:g}: not a finite number within ±{MAX_RETURN:g}")
        out.append((step, task, value, line))
    if not out:
        raise RunError(f"{path}: no evaluations")
    return out


def _row(text: str, path: Path, line: int) -> tuple[int, int, int, float]:
    fields = text.split(",")
    expected = f"{path}:{line}: expected step,task,episodes,mean_return"
    if len(fields) != len(COLUMNS):
        raise RunError(f"{expected}: {len(fields)} fields")
    for name, value in zip(COLUMNS, fields):
        if not _FIELD.fullmatch(value):
            shown = value[:40] + (f"... ({len(value):,} characters)" if len(value) > 40 else "")
            raise RunError(f"{expected}: {name} {shown!r}: not a number of at most 40 characters")
    try:
        return int(fields[0]), int(fields[1]), int(fields[2]), float(fields[3])
    except ValueError:
        raise RunError(f"{expected}: {','.join(fields)}") from None


def _blocks(rows: list[Row], tasks: int, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Rows in blocks of every task, in order, steps going forward."""
    if len(rows) % tasks:
        raise RunError(f"{path}: {len(rows)} rows are not whole blocks of {tasks} tasks")
    steps, returns = [], []
    for b in range(len(rows) // tasks):
        block = rows[b * tasks : (b + 1) * tasks]
        line = block[0][3]
        if sorted(r[1] for r in block) != list(range(tasks)) or len({r[0] for r in block}) != 1:
            raise RunError(f"{path}:{line}: block {b} does not evaluate every task once")
        if steps and block[0][0] <= steps[-1]:
            raise RunError(
                f"{path}:{line}: block {b} at step {block[0][0]}, after step {steps[-1]}: "
                "evaluation steps go backwards"
            )
        steps.append(block[0][0])
        returns.append([r[2] for r in sorted(block, key=lambda r: r[1])])
    return np.array(steps, float), np.array(returns, float)


def _curve(rows: list[Row], task: int, path: Path) -> tuple[np.ndarray, np.ndarray]:
    mine = [r for r in rows if r[1] == task]
    if not mine:
        raise RunError(f"{path}: the reference never evaluates task {task}")
    for before, row in zip(mine, mine[1:]):
        if row[0] <= before[0]:
            raise RunError(
                f"{path}:{row[3]}: task {task} at step {row[0]}, after step {before[0]}: "
                "evaluation steps go backwards"
            )
    return np.array([r[0] for r in mine], float), np.array([r[2] for r in mine], float)


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
