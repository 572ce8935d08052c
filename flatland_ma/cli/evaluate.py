"""``flatland-ma evaluate``: a policy on a suite (table, JSON and plot), or cross-play."""

from __future__ import annotations

import sys
from argparse import ArgumentTypeError
from pathlib import Path

import flatland_ma.cli.options as options
from flatland_ma.cli.options import OptionError
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import load_scenario

CROSSPLAY_EPISODES = 4
"""Episodes per pair of policies in cross-play, unless ``--episodes`` says."""


def add_parser(commands) -> None:
    evaluate = commands.add_parser(
        "evaluate",
        help="a policy against held-out partners: a suite's normalised scores, IQM and 95%% CI",
        description="Score POLICY (a shipped policy's name or a checkpoint saved by the "
        "baselines) on each task of a suite, beside each held-out background policy; each "
        "task normalised so that random play scores 0 and its best scripted policy 1; the "
        "interquartile mean over every run with a stratified bootstrap 95% interval. Writes "
        "evaluation.json and evaluation.png to --out. With --crossplay: every pair of the "
        "given policies, one per team, and their Elo ratings.",
    )
    evaluate.add_argument(
        "policy",
        nargs="?",
        type=options.policy,
        help="a shipped policy's name or a checkpoint file (not with --crossplay or --list)",
    )
    evaluate.add_argument(
        "--suite",
        type=options.suite,
        default=None,
        help="a shipped suite or a suite file (default: society; not with --crossplay)",
    )
    evaluate.add_argument(
        "--episodes",
        type=options.positive(options.MAX_EPISODES),
        default=None,
        help=f"per background, or per pair with --crossplay (default: the suite's, or "
        f"{CROSSPLAY_EPISODES})",
    )
    evaluate.add_argument(
        "--seed", type=options.seed, default=0, help="the first episode's (default: 0)"
    )
    evaluate.add_argument(
        "--out",
        type=options.output_folder,
        default=None,
        help="folder for the JSON and the plot, made if missing (default: "
        "runs/evaluate/<suite>/<policy>, or runs/evaluate/crossplay/<scenario>)",
    )
    evaluate.add_argument("--no-plot", action="store_true", help="write the JSON only")
    evaluate.add_argument(
        "--crossplay",
        nargs="+",
        type=options.policy,
        metavar="POLICY",
        default=None,
        help="instead: two or more different policies, each driving the first team against "
        "each other driving the rest, and their Elo ratings",
    )
    evaluate.add_argument(
        "--scenario",
        default=None,
        help="with --crossplay: a scenario of two teams or more (default: tug_of_war)",
    )
    evaluate.add_argument("--list", action="store_true", help="instead: the shipped suites")


def check(args) -> None:
    """``OptionError`` unless the options make one of the three uses: ``--list``,
    ``--crossplay`` (two different policies or more, a scenario of teams) or a POLICY on a
    suite; the default output folder is checked like a given one."""
    if args.list:
        return
    if args.crossplay is None:
        if args.policy is None:
            raise OptionError("policy", "give a POLICY (or --crossplay, --list)")
        if args.scenario is not None:
            raise OptionError("--scenario", "only with --crossplay (a suite names its scenarios)")
        args.suite = args.suite or "society"
        if args.out is None:
            default = Path("runs") / "evaluate" / Path(args.suite).stem / Path(args.policy).stem
            args.out = _folder(default)
        return
    if args.policy is not None:
        raise OptionError("policy", "not with --crossplay, whose policies follow it")
    if args.suite is not None:
        raise OptionError("--suite", "not with --crossplay (it plays one --scenario)")
    if len(args.crossplay) < 2 or len(set(args.crossplay)) < len(args.crossplay):
        raise OptionError("--crossplay", "give two or more different policies")
    args.scenario = args.scenario or "tug_of_war"
    try:
        teams = load_scenario(args.scenario).teams
    except (ScenarioError, ValueError) as err:
        raise OptionError("--scenario", str(err)) from None
    if len(teams) < 2:
        raise OptionError(
            "--scenario",
            f"cross-play needs a scenario of two teams or more; {args.scenario} has "
            f"{len(teams) or 'none'}",
        )
    if args.out is None:
        args.out = _folder(Path("runs") / "evaluate" / "crossplay" / Path(args.scenario).stem)


def _folder(default: Path) -> Path:
    try:
        return options.output_folder(str(default))
    except ArgumentTypeError as err:
        raise OptionError("--out", f"(default) {err}") from None


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
        episodes = args.episodes or CROSSPLAY_EPISODES
        try:
            result = crossplay(args.scenario, args.crossplay, episodes, args.seed)
        except (ValueError, ScenarioError) as err:  # e.g. a checkpoint for other spaces
            print(f"flatland-ma evaluate: {err}", file=sys.stderr)
            return 2
        names = [Path(p).name for p in result["policies"]]
        print(f"{'first team / others':20}" + "".join(f"{n:>12}" for n in names) + f"{'Elo':>8}")
        for i, (name, row, rating) in enumerate(zip(names, result["wins"], result["elo"])):
            cells = "".join(f"{'-':>12}" if i == j else f"{w:12.2f}" for j, w in enumerate(row))
            print(f"{name:20}{cells}{rating:8.0f}")
        out = Path(args.out or Path("runs") / "evaluate" / "crossplay" / args.scenario)
        for path in write_crossplay(result, out, plot=not args.no_plot):
            print(f"wrote {path}")
        return 0
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
