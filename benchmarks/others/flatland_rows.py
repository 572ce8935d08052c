"""flatland_ma's rows for the comparison with other systems: the batched env over the same
numbers of worlds and agents, with the 64-ray RGB-D camera (the paper's) and with a 64-ray
lidar in its place (what VMAS's agents carry), at one process and every core. Prints JSON
lines like vmas_lidar.py's.

    python flatland_rows.py --worlds 1 16 256 1024 --seconds 3
"""

from __future__ import annotations

import argparse
import json

import flatland_ma
from flatland_ma.bench.scale import bench_worlds, cores

SENSORS = {"camera": {}, "lidar": {"agent": {"sensors": [{"type": "lidar", "rays": 64}]}}}
SCENARIOS = {1: "fruits_poisons", 4: "fruits_poisons_multi"}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--worlds", type=int, nargs="+", default=[1, 16, 256, 1024])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--sensors", nargs="+", default=list(SENSORS))
    args = parser.parse_args()
    for processes in sorted({1, cores()}):
        for sensor in args.sensors:
            for agents, scenario in SCENARIOS.items():
                for worlds in args.worlds:
                    if processes > worlds:
                        continue
                    r = bench_worlds(scenario, worlds, processes, args.seconds,
                                     **SENSORS[sensor])  # fmt: skip
                    row = {"system": f"flatland_ma {flatland_ma.__version__} ({sensor})",
                           "processes": processes, "agents": agents, "worlds": worlds,
                           "world_steps_per_s": r.env_steps_per_s,
                           "agent_steps_per_s": r.agent_steps_per_s,
                           "bare_physics_per_s": r.bare_steps_per_s}  # fmt: skip
                    print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
