"""docs/performance.md's tables of the latest `flatland-ma bench --scale --json` run and of
flatland_ma beside VMAS (benchmarks/peers.py), written from their JSON (committed in
benchmarks/results/scale.json and peers.json), so that the page holds what was measured,
with each row's threads and load.

    flatland-ma bench --scale --json > benchmarks/results/scale.json   # a new measurement
    VMAS_PYTHON=.venv-vmas/bin/python python -m benchmarks.peers        # VMAS beside it
    python -m benchmarks.performance_table                               # rewrite the page

``make performance-page`` does all three, one after another. The tables sit between the
page's ``<!-- scale-json -->`` and ``<!-- peers-json -->`` marks and their closing marks;
tests/test_performance_page.py checks that they are what this module writes from the
committed JSON."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "scale.json"
PEERS = ROOT / "benchmarks" / "results" / "peers.json"
PAGE = ROOT / "docs" / "performance.md"
BEGIN, END = "<!-- scale-json -->", "<!-- /scale-json -->"
PEERS_BEGIN, PEERS_END = "<!-- peers-json -->", "<!-- /peers-json -->"


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
    text = "\n".join(lines) + "\n\n" + "\n".join(notes)
    if data.get("breakdown"):
        text += "\n\n" + breakdown_table(data["breakdown"])
    return text


def breakdown_table(rows: list[dict]) -> str:
    """Where a world-step goes (``flatland_ma.bench.breakdown``), one line per row."""
    lines = [
        "| where a world-step goes, us of CPU | step | physics | rays | rest "
        "| reset (its share) | total | bare physics |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['scenario']} x {r['worlds']} ({r['agents']} agents) | {r['step']:.1f} "
            f"| {r['physics']:.1f} | {r['rays']:.1f} | {r['rest']:.1f} "
            f"| {r['reset'] / 1000:.1f} ms / {r['step_limit']} steps ({r['reset_share']:.1f}) "
            f"| {r['total']:.1f} | {r['bare']:.1f} |"
        )
    return "\n".join(lines)


def _cell(row: dict | None) -> str:
    if row is None:
        return "-"
    return _number(row["agent_steps_per_s"]) + (" (BUSY)" if row["busy"] else "")


def peers_table(data: dict) -> str:
    """flatland_ma beside VMAS (benchmarks/peers.py), one line per size and core count."""
    found: dict[tuple[int, int], dict[str, dict]] = {}
    for row in data["rows"]:
        system = "vmas" if row["system"].startswith("vmas") else row["sensor"]
        found.setdefault((row["cores"], row["worlds"]), {})[system] = row
    versions = sorted({row["system"] for row in data["rows"]})
    lines = [
        "| worlds x agents | cores | VMAS, lidar | flatland_ma, lidar | flatland_ma, camera "
        "| flatland_ma camera / VMAS | load |",
        "|---|---|---|---|---|---|---|",
    ]
    for (n_cores, worlds), systems in sorted(found.items()):
        vmas, camera = systems.get("vmas"), systems.get("camera")
        ratio = (
            f"{camera['agent_steps_per_s'] / vmas['agent_steps_per_s']:.1f}x"
            if vmas and camera
            else "-"
        )
        loads = [row["load_average"] for row in systems.values()]
        agents = next(iter(systems.values()))["agents"]
        lines.append(
            f"| {worlds} x {agents} | {n_cores} | {_cell(vmas)} | {_cell(systems.get('lidar'))} "
            f"| {_cell(camera)} | {ratio} | {min(loads):.2f}-{max(loads):.2f} |"
        )
    note = f"- Agent steps per second; {', '.join(versions)}; scenario {data['scenario']}."
    return "\n".join(lines) + "\n\n" + note


def _replace(page: str, begin: str, end: str, text: str) -> str:
    head, found_begin, rest = page.partition(begin)
    _, found_end, tail = rest.partition(end)
    if not found_begin or not found_end:
        raise ValueError(f"the page has no {begin} ... {end} section")
    return f"{head}{begin}\n{text}\n{end}{tail}"


def rewrite(page: str, data: dict, peers: dict | None = None) -> str:
    """``page`` with the text between the marks replaced by the table of ``data``, and the
    text between the peers marks by the table of ``peers`` if given."""
    page = _replace(page, BEGIN, END, table(data))
    if peers is not None:
        page = _replace(page, PEERS_BEGIN, PEERS_END, peers_table(peers))
    return page


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=RESULTS)
    parser.add_argument("--peers", type=Path, default=PEERS)
    parser.add_argument("--page", type=Path, default=PAGE)
    args = parser.parse_args(argv)
    data = json.loads(args.results.read_text())
    peers = json.loads(args.peers.read_text()) if args.peers.exists() else None
    args.page.write_text(rewrite(args.page.read_text(), data, peers))


if __name__ == "__main__":
    main()
