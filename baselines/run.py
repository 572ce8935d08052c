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


def child_env() -> dict[str, str]:
    """The seeds' environment: single-threaded, with this checkout on the path."""
    package_root = str(Path(__file__).resolve().parent.parent)
    return {
        **os.environ,
        **SINGLE_THREADED,
        "PYTHONPATH": os.pathsep.join(filter(None, [package_root, os.environ.get("PYTHONPATH")])),
    }


class Seeds:
    """The seeds running at once, each a process with its own progress bar."""

    def __init__(self, args: argparse.Namespace, extra: list[str], scenario: str, directory: Path):
        self.args, self.extra, self.scenario, self.directory = args, extra, scenario, directory
        self.env = child_env()
        self.running: dict[int, tuple[subprocess.Popen, tqdm]] = {}
        self.failed: list[int] = []
        self.done_steps = 0
        self.free_rows = list(range(1, args.workers + 1))  # screen rows of the per-seed bars

    def command(self, seed: int) -> list[str]:
        module, fixed = MODULES[self.args.algo]
        return [
            sys.executable,
            "-m",
            f"baselines.{module}",
            *fixed,
            "--seed",
            str(seed),
            "--scenario",
            self.scenario,
            "--total-timesteps",
            str(self.args.steps),
            "--csv",
            str(self.directory / f"seed_{seed}.csv"),
            *self.extra,
        ]

    def start(self, seed: int) -> None:
        with open(self.directory / f"seed_{seed}.log", "w") as log:
            process = subprocess.Popen(
                self.command(seed), stdout=log, stderr=subprocess.STDOUT, env=self.env
            )
        bar = tqdm(
            total=self.args.steps,
            desc=f"  seed {seed}",
            unit="step",
            leave=False,
            position=self.free_rows.pop(0),
            dynamic_ncols=True,
        )
        self.running[seed] = (process, bar)

    def poll(self) -> None:
        """Move each seed's bar to its CSV's last step; close the finished seeds'."""
        steps = self.args.steps
        for seed, (process, bar) in list(self.running.items()):
            finished = process.poll() is not None
            step = steps if finished else last_step(self.directory / f"seed_{seed}.csv.part")
            bar.update(max(0, min(step, steps) - bar.n))
            if not finished:
                continue
            self.free_rows.append(abs(bar.pos))
            bar.close()
            del self.running[seed]
            self.done_steps += steps
            if process.returncode == 0:
                tqdm.write(f"seed {seed} done: {self.directory / f'seed_{seed}.csv'}")
            else:
                self.failed.append(seed)
                tail = (self.directory / f"seed_{seed}.log").read_text().splitlines()[-15:]
                tqdm.write(f"seed {seed} failed (exit {process.returncode}):\n" + "\n".join(tail))

    def steps_done(self) -> int:
        return self.done_steps + sum(b.n for _, b in self.running.values())

    def stop(self) -> None:
        for process, _ in self.running.values():
            process.terminate()


def main(argv: list[str] | None = None) -> int:
    args, extra = parse(sys.argv[1:] if argv is None else argv)
    scenario = args.scenario or ("fruits_poisons_multi" if args.algo == "ppo" else "fruits_poisons")
    directory = Path(args.out) / (args.name or args.algo) / scenario
    directory.mkdir(parents=True, exist_ok=True)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    todo = [seed for seed in seeds if not (directory / f"seed_{seed}.csv").exists()]
    if len(todo) < len(seeds):
        print(f"{len(seeds) - len(todo)} of {len(seeds)} seeds already complete in {directory}")
    overall = tqdm(
        total=len(todo) * args.steps,
        desc=f"{args.algo} {scenario}",
        unit="step",
        position=0,
        dynamic_ncols=True,
    )
    pool, pending = Seeds(args, extra, scenario, directory), list(todo)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # stops the seeds too, below
    try:
        while pending or pool.running:
            while pending and len(pool.running) < args.workers:
                pool.start(pending.pop(0))
            time.sleep(1.0)
            pool.poll()
            overall.update(pool.steps_done() - overall.n)
    finally:
        pool.stop()
    overall.close()
    if pool.failed:
        print(f"failed seeds: {pool.failed}; their logs are in {directory}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
