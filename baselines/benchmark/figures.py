"""The benchmark's figures: each tier's normalised PPO scores per task, and each
scenario's learning curve (``baselines.benchmark.curves``) from its PPO records."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from baselines.benchmark.curves import draw_curves, task_curve
from baselines.benchmark.records import read_results
from baselines.benchmark.settings import BenchmarkConfig


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
