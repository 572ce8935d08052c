"""The benchmark's page, docs/benchmark.md, rebuilt from the committed per-seed JSON files
alone (no training): every shipped scenario and stream, random / scripted / open-loop play
and PPO with 95% intervals, a section per tier of PPO (smoke, standard, certificate) with
its budgets, configurations, verdicts, whether PPO beats open-loop play, and each seed's
CPU time, load and calibration.

    python -m baselines.benchmark.table          # make benchmark-table

Scores are normalised per task, random play 0 and the scripted reference 1 (the means of
their seeds); a task whose scripted play does not beat random play has no scale, and the
page says so. Each figure is the interquartile mean over seeds with a 95% stratified
bootstrap interval (``flatland_ma.evaluation.stats``, as the evaluation suites report
them); a tier's aggregate pools the normalised PPO seeds of every task that has them.

Also written: ``results/benchmark/summary.json`` (each task's figures, which the
catalogue's scenario pages show), ``docs/images/benchmark.png`` (smoke) and
``benchmark_<tier>.png`` (the other tiers, once run), and each scenario's learning curve,
``docs/images/curves/<task>.png``, from the curves its PPO records hold
(``baselines.benchmark.curves``). The figures come from ``summary.py``, the page's
Markdown from ``page.py`` and the images from ``figures.py``.
"""

from __future__ import annotations

import json
from pathlib import Path

from baselines.benchmark.figures import curves, draw
from baselines.benchmark.levels import LEVELS_OUT
from baselines.benchmark.page import figure_path, render
from baselines.benchmark.records import OUT
from baselines.benchmark.settings import ROOT, SETTINGS, load_config
from baselines.benchmark.summary import build, scenario_summary

PAGE = ROOT / "docs" / "benchmark.md"
CURVES = Path("images") / "curves"
"""Each scenario's learning curve, ``<task>.png``, under docs/."""


def write(
    root: Path = OUT,
    config_path: str | Path = SETTINGS,
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
