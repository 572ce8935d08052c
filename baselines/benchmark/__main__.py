"""``python -m baselines.benchmark``: run the benchmark's methods on its tasks, every seed
not yet written (the package's docstring says what each does).

    python -m baselines.benchmark                        # the smoke tier: all not yet done
    python -m baselines.benchmark --tier standard        # 1M agent-steps x 5 seeds
    python -m baselines.benchmark --methods random scripted open_loop
    python -m baselines.benchmark --only fruits_poisons coop_carry --methods ppo
"""

from __future__ import annotations

import argparse
from pathlib import Path

from baselines.benchmark.play import list_tasks
from baselines.benchmark.records import OUT, RUNS
from baselines.benchmark.runs import run
from baselines.benchmark.settings import METHODS, SETTINGS, TIERS, load_config

DESCRIPTION = (
    "The benchmark: random play, open-loop play, each task's scripted reference solver and "
    "shared-parameter PPO (in tiers of budget) on every shipped scenario and task stream, seed "
    "by seed, one small JSON file per seed."
)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m baselines.benchmark", description=DESCRIPTION)
    parser.add_argument("--config", default=str(SETTINGS))
    parser.add_argument(
        "--tier", choices=TIERS, default="smoke", help="PPO's budgets and seeds (default smoke)"
    )
    parser.add_argument("--only", nargs="+", default=None, help="these tasks only")
    parser.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    parser.add_argument("--out", default=str(OUT), help="where the JSON results go")
    parser.add_argument("--runs", default=str(RUNS), help="where checkpoints and logs go")
    parser.add_argument(
        "--hours", type=float, default=0.0, help="start no seed after this many hours (0: none)"
    )
    args = parser.parse_args(argv)
    tasks = list_tasks()
    if args.only:
        known = {name for name, _ in tasks}
        unknown = sorted(set(args.only) - known)
        if unknown:
            parser.error(f"no shipped scenario or stream {', '.join(unknown)}")
        tasks = [t for t in tasks if t[0] in args.only]
    config = load_config(args.config)
    if args.tier not in config.tiers:
        parser.error(f"{args.config}: tiers: no tier {args.tier}")
    shipped = {name for name, _ in list_tasks()}
    for name, level in config.tiers.items():
        strangers = sorted((set(level.tasks) | set(level.only or [])) - shipped)
        if strangers:
            parser.error(
                f"{args.config}: tiers.{name}: no shipped scenario or stream "
                + ", ".join(strangers)
            )
    run(config, tasks, args.methods, Path(args.out), Path(args.runs), args.hours, args.tier)


if __name__ == "__main__":
    main()
