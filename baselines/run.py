"""Run an algorithm over many seeds, each in its own single-threaded process.

    python -m baselines.run dqn --scenario fruits_poisons --seeds 30 --workers 2 \\
        --steps 250000 --out runs

Seed k of ALGO writes ``OUT/NAME/SCENARIO/seed_k.csv`` (NAME defaults to ALGO), its
summary ``seed_k.json`` and its console output ``seed_k.log``. A run in progress writes
``seed_k.csv.part``; a seed whose ``.csv`` exists is complete and is skipped, so running
the same command again resumes (an interrupted seed starts over). Arguments after ``--``
go to the algorithm, e.g. ``-- --use-depth``. ``a2c`` is ``a3c --mode a2c``. An A3C seed
already runs 5 processes: give it ``--workers 1``.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from tqdm import tqdm

MODULES = {
    "dqn": ("dqn", []),
    "a3c": ("a3c", []),
    "a2c": ("a3c", ["--mode", "a2c"]),
    "dfp": ("dfp", []),
    "ppo": ("ppo", []),
}
"""Algorithm name -> (module in baselines, fixed arguments)."""

SINGLE_THREADED = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


def last_step(part: Path) -> int:
    """The step column of the last row of a run's CSV in progress (0 if none yet)."""
    try:
        with open(part, "rb") as f:
            f.seek(max(0, f.seek(0, os.SEEK_END) - 512))
            last = f.read().decode(errors="replace").strip().splitlines()[-1]
        return int(last.split(",")[2])
    except (OSError, ValueError, IndexError):  # no file yet, only the header, a partial line
        return 0


def parse(argv: list[str]) -> tuple[argparse.Namespace, list[str]]:
    extra = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1 :]
        argv = argv[: argv.index("--")]
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("algo", choices=sorted(MODULES), help="algorithm to run")
    parser.add_argument(
        "--scenario",
        default=None,
        help="scenario (default: fruits_poisons; fruits_poisons_multi for ppo)",
    )
    parser.add_argument("--seeds", type=int, default=30, help="number of seeds (default: 30)")
    parser.add_argument("--first-seed", type=int, default=0, help="first seed (default: 0)")
    parser.add_argument(
        "--workers",
        type=int,
        default=2,
        help="seeds run at the same time, one process each (default: 2)",
    )
    parser.add_argument(
        "--steps",
        type=int,
        default=250_000,
        help="steps per seed; agent-steps for ppo (default: 250000)",
    )
    parser.add_argument("--out", default="runs", help="output directory (default: runs)")
    parser.add_argument("--name", default=None, help="directory name of the runs (default: ALGO)")
    return parser.parse_args(argv), extra


def main(argv: list[str] | None = None) -> int:
    args, extra = parse(sys.argv[1:] if argv is None else argv)
    module, fixed = MODULES[args.algo]
    scenario = args.scenario or ("fruits_poisons_multi" if args.algo == "ppo" else "fruits_poisons")
    directory = Path(args.out) / (args.name or args.algo) / scenario
    directory.mkdir(parents=True, exist_ok=True)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    todo = [seed for seed in seeds if not (directory / f"seed_{seed}.csv").exists()]
    if len(todo) < len(seeds):
        print(f"{len(seeds) - len(todo)} of {len(seeds)} seeds already complete in {directory}")

    package_root = str(Path(__file__).resolve().parent.parent)
    env = {
        **os.environ,
        **SINGLE_THREADED,
        "PYTHONPATH": os.pathsep.join(filter(None, [package_root, os.environ.get("PYTHONPATH")])),
    }
    overall = tqdm(
        total=len(todo) * args.steps,
        desc=f"{args.algo} {scenario}",
        unit="step",
        position=0,
        dynamic_ncols=True,
    )
    running: dict[int, tuple[subprocess.Popen, tqdm]] = {}
    failed, pending, done_steps = [], list(todo), 0
    free_rows = list(range(1, args.workers + 1))  # screen rows of the per-seed bars
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # stops the seeds too, below
    try:
        while pending or running:
            while pending and len(running) < args.workers:
                seed = pending.pop(0)
                command = [
                    sys.executable,
                    "-m",
                    f"baselines.{module}",
                    *fixed,
                    "--seed",
                    str(seed),
                    "--scenario",
                    scenario,
                    "--total-timesteps",
                    str(args.steps),
                    "--csv",
                    str(directory / f"seed_{seed}.csv"),
                    *extra,
                ]
                with open(directory / f"seed_{seed}.log", "w") as log:
                    process = subprocess.Popen(
                        command, stdout=log, stderr=subprocess.STDOUT, env=env
                    )
                bar = tqdm(
                    total=args.steps,
                    desc=f"  seed {seed}",
                    unit="step",
                    leave=False,
                    position=free_rows.pop(0),
                    dynamic_ncols=True,
                )
                running[seed] = (process, bar)
            time.sleep(1.0)
            for seed, (process, bar) in list(running.items()):
                finished = process.poll() is not None
                step = args.steps if finished else last_step(directory / f"seed_{seed}.csv.part")
                bar.update(max(0, min(step, args.steps) - bar.n))
                if not finished:
                    continue
                free_rows.append(abs(bar.pos))
                bar.close()
                del running[seed]
                done_steps += args.steps
                if process.returncode == 0:
                    tqdm.write(f"seed {seed} done: {directory / f'seed_{seed}.csv'}")
                else:
                    failed.append(seed)
                    tail = (directory / f"seed_{seed}.log").read_text().splitlines()[-15:]
                    tqdm.write(
                        f"seed {seed} failed (exit {process.returncode}):\n" + "\n".join(tail)
                    )
            overall.update(done_steps + sum(b.n for _, b in running.values()) - overall.n)
    finally:
        for process, _ in running.values():
            process.terminate()
    overall.close()
    if failed:
        print(f"failed seeds: {failed}; their logs are in {directory}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
