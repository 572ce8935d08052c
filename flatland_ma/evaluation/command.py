"""``flatland-ma evaluate``: a policy on a suite (table, JSON and plot), or cross-play."""

from __future__ import annotations

import sys
from pathlib import Path

from flatland_ma.scenario.errors import ScenarioError


def add_parser(commands) -> None:
    evaluate = commands.add_parser(
        "evaluate",
        help="a policy against held-out partners: a suite's normalised scores, IQM and 95%% CI",
        description="Score POLICY (a shipped policy's name or a checkpoint saved by the "
        "baselines) on each task of a suite, beside each held-out background policy; each "
        "task normalised so that random play scores 0 and its best scripted policy 1; the "
        "interquartile mean over every run with a stratified bootstrap 95%% interval. Writes "
        "evaluation.json and evaluation.png to --out. With --crossplay: every pair of the "
        "given policies, one per team, and their Elo ratings.",
    )
    evaluate.add_argument("policy", nargs="?", help="shipped policy name or checkpoint path")
    evaluate.add_argument("--suite", default="society", help="a shipped suite or a suite file")
    evaluate.add_argument(
        "--episodes", type=int, default=None, help="per background (default: the suite's)"
    )
    evaluate.add_argument("--seed", type=int, default=0)
    evaluate.add_argument("--out", default=None, help="folder for the JSON and the plot")
    evaluate.add_argument("--no-plot", action="store_true")
    evaluate.add_argument("--crossplay", nargs="+", metavar="POLICY", default=None)
    evaluate.add_argument("--scenario", default="tug_of_war", help="with --crossplay")
    evaluate.add_argument("--list", action="store_true", help="the shipped suites")


def run(args) -> int:
    from flatland_ma.evaluation.runner import (
        crossplay,
        run_suite,
        table,
        write_crossplay,
        write_report,
    )
    from flatland_ma.evaluation.suite import list_suites, load_suite

    if args.list:
        print("\n".join(list_suites()))
        return 0
    if args.crossplay is not None:
        result = crossplay(args.scenario, args.crossplay, args.episodes or 4, args.seed)
        names = [Path(p).name for p in result["policies"]]
        print(f"{'first team / others':20}" + "".join(f"{n:>12}" for n in names) + f"{'Elo':>8}")
        for i, (name, row, rating) in enumerate(zip(names, result["wins"], result["elo"])):
            cells = "".join(f"{'-':>12}" if i == j else f"{w:12.2f}" for j, w in enumerate(row))
            print(f"{name:20}{cells}{rating:8.0f}")
        out = Path(args.out or Path("runs") / "evaluate" / "crossplay" / args.scenario)
        for path in write_crossplay(result, out, plot=not args.no_plot):
            print(f"wrote {path}")
        return 0
    if args.policy is None:
        print("flatland-ma evaluate: give a POLICY (or --crossplay, --list)", file=sys.stderr)
        return 2
    try:
        suite = load_suite(args.suite)
        result = run_suite(
            suite,
            args.policy,
            seed=args.seed,
            episodes=args.episodes,
            progress=lambda line: print(line, file=sys.stderr),
        )
    except (ValueError, FileNotFoundError, ScenarioError) as err:
        print(f"flatland-ma evaluate: {err}", file=sys.stderr)
        return 2
    result["suite"] = str(args.suite)
    print(table(result))
    out = Path(
        args.out or Path("runs") / "evaluate" / Path(str(args.suite)).stem / Path(args.policy).stem
    )
    for path in write_report(result, out, plot=not args.no_plot):
        print(f"wrote {path}")
    return 0
