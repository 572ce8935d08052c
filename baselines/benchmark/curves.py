"""PPO's learning curves for the benchmark: each seed's compact curve, read from its
training log and kept in its result JSON (so the logs need not be committed), and each
task's figure, drawn from the committed JSON alone.

A seed's curve: ``POINTS`` checkpoints at equal steps of agent-steps up to the budget; at
each, the mean training return of the episodes that ended since the previous checkpoint
(an episode's return: the mean over its world's agents of each agent's own, unshaped
return, as the log keeps it), or none if no episode ended there. This is the return while
training, not the held-out score: with ``carrier_vs_random`` every agent is the learner.
A task's curve: at each checkpoint, the interquartile mean over the seeds that have a
point there, with its 95% bootstrap interval (``flatland_ma.evaluation.stats``).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from flatland_ma.evaluation.stats import stratified_bootstrap

POINTS = 50
"""Checkpoints per seed's curve."""
CURVE_REPS = 1000
"""Bootstrap resamples per checkpoint of a task's curve."""


def seed_curve(log: str | Path, budget: int, points: int = POINTS) -> dict:
    """The curve of one run from its CSV log (``baselines.common.RunLog``: one row per
    episode and agent): ``{"steps": [...], "returns": [mean or None, ...]}``."""
    if budget < 1 or points < 1:
        raise ValueError(f"a curve needs a budget and points of at least 1, not {budget}, {points}")
    episodes: dict[str, tuple[int, list[float]]] = {}
    with open(log, newline="", encoding="utf-8") as f:
        for row in csv.DictReader(f):
            step, returns = episodes.setdefault(row["episode"], (int(row["step"]), []))
            returns.append(float(row["return"]))
    steps = [round(budget * (k + 1) / points) for k in range(points)]
    ends = np.array([s for s, _ in episodes.values()], np.int64)
    means = np.array([float(np.mean(r)) for _, r in episodes.values()])
    out: list[float | None] = []
    for k, step in enumerate(steps):
        start = steps[k - 1] if k else -1
        if k == points - 1:
            step = max(step, int(ends.max(initial=step)))  # the last rollout may overrun
        inside = (ends > start) & (ends <= step)
        out.append(round(float(means[inside].mean()), 4) if inside.any() else None)
    return {"steps": steps, "returns": out}


def task_curve(curves: list[dict]) -> dict | None:
    """IQM over seeds at each checkpoint and its 95% interval, from seeds' curves of one
    budget: ``{"steps", "iqm", "low", "high", "seeds"}`` (None where no seed has a
    point); None if no seed has a curve."""
    curves = [c for c in curves if c]
    if not curves:
        return None
    steps = curves[0]["steps"]
    if any(c["steps"] != steps for c in curves):
        raise ValueError("the seeds' curves have different checkpoints (different budgets)")
    out: dict = {"steps": steps, "iqm": [], "low": [], "high": [], "seeds": []}
    for k in range(len(steps)):
        values = [c["returns"][k] for c in curves if c["returns"][k] is not None]
        point = stratified_bootstrap([values], reps=CURVE_REPS) if values else (None,) * 3
        for key, value in zip(("iqm", "low", "high"), point):
            out[key].append(value)
        out["seeds"].append(len(values))
    return out


def draw_curves(name: str, tiers: dict[str, dict], lines: dict[str, float], path: Path) -> None:
    """Task ``name``'s figure: each tier's curve (IQM, its interval shaded) over agent-steps,
    and ``lines`` (e.g. random and scripted play's held-out scores) as horizontal lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    colours = {"smoke": "tab:grey", "standard": "tab:blue", "certificate": "tab:purple"}
    last = 1
    for tier, curve in tiers.items():
        x = np.array(curve["steps"], np.float64)
        y = np.array([math.nan if v is None else v for v in curve["iqm"]])
        low = np.array([math.nan if v is None else v for v in curve["low"]])
        high = np.array([math.nan if v is None else v for v in curve["high"]])
        seeds = max(curve["seeds"])
        shown = ~np.isnan(y)
        colour = colours.get(tier, None)
        label = f"PPO, {tier} ({seeds} seed{'s' if seeds != 1 else ''})"
        ax.plot(x[shown], y[shown], color=colour, label=label, marker=".", ms=3)
        ax.fill_between(x[shown], low[shown], high[shown], color=colour, alpha=0.2, lw=0)
        last = max(last, int(x[-1]))
    styles = {"random": ("tab:red", ":"), "scripted": ("tab:green", "--")}
    for label, value in lines.items():
        colour, style = styles.get(label, ("tab:orange", "-."))
        ax.axhline(
            value, color=colour, ls=style, lw=1, label=f"{label.replace('_', '-')} (held-out)"
        )
    budgets = [int(c["steps"][-1]) for c in tiers.values()]
    if budgets and max(budgets) > 10 * min(budgets):
        ax.set_xscale("log")
    ax.set_xlim(right=last)
    ax.set_xlabel("agent-steps of training")
    ax.set_ylabel("return per agent")
    ax.set_title(f"{name}: training return, IQM over seeds (95% interval)", fontsize=10)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90, metadata={"Software": None})
    plt.close(fig)
