"""docs/performance.md's table of the latest `flatland-ma bench --scale --json` run, written
from its JSON (committed in benchmarks/results/scale.json), so that the page holds what
the bench measured, with each row's threads and load.

    flatland-ma bench --scale --json > benchmarks/results/scale.json   # a new measurement
    python -m benchmarks.performance_table                               # rewrite the page

``make performance-page`` does both. The table sits between the page's ``<!-- scale-json
-->`` and ``<!-- /scale-json -->`` marks; tests/test_performance_page.py checks that it is
what this module writes from the committed JSON."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "scale.json"
PAGE = ROOT / "docs" / "performance.md"
BEGIN, END = "<!-- scale-json -->", "<!-- /scale-json -->"


def _number(value: float | None) -> str:
    return "-" if value is None else f"{value:,.0f}"


def table(data: dict) -> str:
    """The rows of the run, then the ray kernel's and PPO's figures, as Markdown."""
    lines = [
        "| run | agents | world steps/s | agent steps/s | bare physics world steps/s "
        "| cost / bare | threads | other processes' cores | load | busy |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in data["batched"]:
        bare, world = row["bare_space_step_per_s"], row["world_steps_per_s"]
        cost = f"{bare / world:.1f}x" if bare else "-"
        lines.append(
            f"| {row['environment']} | {row['agents']} | {_number(world)} "
            f"| {_number(row['agent_steps_per_s'])} | {_number(bare)} | {cost} "
            f"| {row['threads']} | {row['other_cores']:.2f} | {row['load_average']:.2f} "
            f"| {'BUSY' if row['busy'] else ''} |"
        )
    rays = data.get("rays")
    notes = []
    if rays:
        notes.append(f"- {rays['run']}: {rays['rays_per_s_per_core'] / 1e6:.1f} M rays/s per core.")
    for run in data.get("training", []):
        note = f" ({run['note']})" if run.get("note") else ""
        notes.append(f"- {run['run']}: {_number(run['agent_steps_per_s'])} agent-steps/s{note}.")
    notes.append(f"- Cores: {data['cores']}; numpy {data['numpy']}.")
    return "\n".join(lines) + "\n\n" + "\n".join(notes)


def rewrite(page: str, data: dict) -> str:
    """``page`` with the text between the marks replaced by the table of ``data``."""
    head, begin, rest = page.partition(BEGIN)
    _, end, tail = rest.partition(END)
    if not begin or not end:
        raise ValueError(f"the page has no {BEGIN} ... {END} section")
    return f"{head}{BEGIN}\n{table(data)}\n{END}{tail}"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=RESULTS)
    parser.add_argument("--page", type=Path, default=PAGE)
    args = parser.parse_args(argv)
    data = json.loads(args.results.read_text())
    args.page.write_text(rewrite(args.page.read_text(), data))


if __name__ == "__main__":
    main()
