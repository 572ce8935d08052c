"""flatland_ma beside VMAS in one run, written to benchmarks/results/peers.json.

The same room in both (4 walls, 4 box obstacles, 20 round items, 4 agents per world), the
same numbers of worlds, on one core and on every core. VMAS 1.5.2 runs in an environment of
its own (``VMAS_PYTHON``; ``make performance-page`` builds ``.venv-vmas``), with a 64-ray
lidar per agent (``benchmarks/others/vmas_lidar.py``); flatland_ma's batched env runs with
the same lidar in place of its camera, and with the paper's 64-ray RGB-D camera. For each
size and core count the three rows are taken one after another, so they share the
machine's state; each row records the cores other processes used while it ran and the
load average (``flatland_ma.bench.load``), and is flagged busy when others held a quarter
of a core or more.

    VMAS_PYTHON=.venv-vmas/bin/python python -m benchmarks.peers
    python -m benchmarks.performance_table   # the page's table of it
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import flatland_ma
from flatland_ma.bench.load import LoadMeter
from flatland_ma.bench.scale import cores, timed_steps

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "peers.json"
VMAS_SCRIPT = ROOT / "benchmarks" / "others" / "vmas_lidar.py"
LIDAR: dict[str, Any] = {"agent": {"sensors": [{"type": "lidar", "rays": 64}]}}
SCENARIO = "fruits_poisons_multi"
AGENTS = 4


def vmas_row(python: str, worlds: int, threads: int, seconds: float) -> dict:
    """One VMAS row, run in its own interpreter: its JSON line, with the load."""
    meter = LoadMeter(cores())
    meter.start()
    out = subprocess.run(
        [python, str(VMAS_SCRIPT), "--worlds", str(worlds), "--agents", str(AGENTS),
         "--threads", str(threads), "--seconds", str(seconds)],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    load = meter.stop()
    row = json.loads(out.stdout.strip().splitlines()[-1])
    return {
        "system": row["system"],
        "sensor": "lidar",
        "worlds": worlds,
        "agents": AGENTS,
        "cores": threads,
        "world_steps_per_s": row["world_steps_per_s"],
        "agent_steps_per_s": row["agent_steps_per_s"],
        # The load meter also counts VMAS's start-up (imports, building the worlds).
        "other_cores": load.other_cores,
        "load_average": load.load_average,
        "busy": load.busy,
    }


def flatland_row(sensor: str, worlds: int, processes: int, seconds: float) -> dict:
    """One flatland_ma row: the batched env on one thread (``processes`` 1), or sharded
    over ``processes`` processes of one thread each; with its load."""
    from flatland_ma.envs.shards import ShardedParallelEnv
    from flatland_ma.envs.vector import BatchedParallelEnv

    sensors: dict[str, Any] = LIDAR if sensor == "lidar" else {}
    if processes == 1:
        env = BatchedParallelEnv(SCENARIO, num_worlds=worlds, copy=False, parallel=False,
                                 **sensors)  # fmt: skip
    else:
        env = ShardedParallelEnv(SCENARIO, worlds, shards=processes, copy=False, **sensors)
    try:
        rate, load = timed_steps(env, worlds, seconds)
        agents = env.agents_per_world
    finally:
        env.close()
    return {
        "system": f"flatland_ma {flatland_ma.__version__}",
        "sensor": sensor,
        "worlds": worlds,
        "agents": agents,
        "cores": processes,
        "world_steps_per_s": rate,
        "agent_steps_per_s": rate * agents,
        "other_cores": load.other_cores,
        "load_average": load.load_average,
        "busy": load.busy,
    }


def run(python: str, worlds: list[int], seconds: float) -> dict:
    """Every row: for each core count and size, VMAS, then flatland_ma's lidar and camera."""
    rows = []
    for n_cores in sorted({1, cores()}):
        for n in worlds:
            rows.append(vmas_row(python, n, n_cores, seconds))
            for sensor in ("lidar", "camera"):
                rows.append(flatland_row(sensor, n, n_cores, seconds))
            for row in rows[-3:]:
                print(json.dumps(row), file=sys.stderr, flush=True)
    return {"scenario": SCENARIO, "cores": cores(), "rows": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--worlds", type=int, nargs="+", default=[16, 256, 1024])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--vmas-python", default=os.environ.get("VMAS_PYTHON", ""))
    args = parser.parse_args()
    if not args.vmas_python or not Path(args.vmas_python).exists():
        parser.error("set VMAS_PYTHON (or --vmas-python) to a Python with vmas 1.5.2 installed")
    data = run(args.vmas_python, args.worlds, args.seconds)
    part = args.out.with_suffix(".json.part")
    part.write_text(json.dumps(data, indent=1) + "\n")
    part.replace(args.out)


if __name__ == "__main__":
    main()
