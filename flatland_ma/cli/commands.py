"""The ``flatland-ma`` parser (one subcommand a task) and its small commands: ``list``,
``validate``, ``demo`` and ``record``; the others have a module each in this package
(``keyboard`` for ``play``, ``bench``, ``evaluate``, ``task_streams`` for ``lifelong``,
``convert`` for ``checkpoint``, ``studio``).

Every option has a checked type (``flatland_ma.cli.options``), and each command's checks
that need several options or a loaded scenario run right after parsing: a wrong option
stops the command with status 2 and the option's name, before any work starts.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

import flatland_ma.cli.bench as bench_command
import flatland_ma.cli.convert as convert_command
import flatland_ma.cli.evaluate as evaluation
import flatland_ma.cli.keyboard as keyboard
import flatland_ma.cli.options as options
import flatland_ma.cli.studio as studio
import flatland_ma.cli.task_streams as task_streams
from flatland_ma import __version__
from flatland_ma.cli.options import OptionError
from flatland_ma.kinds.registry import ExtensionError
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import list_scenarios, load_scenario, scenario_path

DESCRIPTION = (
    "Scenarios of a multi-agent, first-person 2-D world: list and check them, watch and "
    "record play, play at the keyboard, measure speed, evaluate policies against suites "
    "and report lifelong-learning runs. Each command has its own --help."
)


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command and option (``subcommands`` finds each command's)."""
    parser = options.CommandParser(prog="flatland-ma", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="command")

    _add_scenario_commands(commands)
    _add_record(commands)
    keyboard.add_parser(commands)
    bench_command.add_parser(commands)
    evaluation.add_parser(commands)
    task_streams.add_parser(commands)
    convert_command.add_parser(commands)
    studio.add_parser(commands)
    return parser


def _add_scenario_commands(commands) -> None:
    """``list``, ``validate`` and ``demo``."""
    commands.add_parser(
        "list",
        help="the shipped scenarios, one line each",
        description="The shipped scenarios, one line each: name, number of agents, "
        "description and, for single-agent ones, the Gymnasium id.",
    )

    validate = commands.add_parser(
        "validate",
        help="check scenario files",
        description="Check scenario files: load each, then build it at several seeds. Each "
        "fault names the file, line and key path; exit status 1 if any file is invalid.",
    )
    validate.add_argument("files", nargs="+", help="scenario files or shipped names")

    demo = commands.add_parser("demo", help="greedy and random play on fruits_poisons")
    demo.add_argument(
        "--episodes",
        type=options.positive(options.MAX_EPISODES),
        default=10,
        help="episodes per policy (default: 10)",
    )
    demo.add_argument(
        "--out",
        type=options.output_folder,
        default="demo",
        help="folder for the GIF and the PNG, made if missing (default: demo)",
    )


def _add_record(commands) -> None:
    """``record``: a GIF, an MP4 or a PNG of play."""
    record = commands.add_parser(
        "record",
        help="write a GIF or an MP4 (and a PNG of its middle frame), or only a PNG, of play",
    )
    record.add_argument("scenario", help="a shipped scenario's name or a scenario file")
    record.add_argument(
        "--policy",
        type=options.policy,
        default="greedy",
        metavar="POLICY",
        help=f"one of {', '.join(options.POLICIES)}, or the path of a checkpoint file saved "
        "by the baselines (default: greedy)",
    )
    record.add_argument(
        "--steps",
        type=options.positive(options.MAX_STEPS),
        default=300,
        help="steps to play at most; the recording also ends with the episode (default: 300)",
    )
    record.add_argument(
        "--every",
        type=options.positive(options.MAX_STEPS),
        default=2,
        help="keep one frame in this many, and the last (default: 2)",
    )
    record.add_argument("--seed", type=options.seed, default=0, help="the episode's (default: 0)")
    record.add_argument(
        "--out",
        type=options.recording,
        default=None,
        help="a .gif or .mp4, or a .png for the last frame only, in a folder that exists "
        "(default: <scenario>.gif)",
    )
    options.world_options(record)


def subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """Each command's parser, by name."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def main(argv: list[str] | None = None) -> int:
    """Run the command ``argv`` (default: the process's arguments); its exit status. A
    wrong option gives 2 and a message naming it, before any work."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        checks: dict[str, Callable] = {
            "record": _check_record,
            "play": options.check_world,
            "bench": bench_command.check,
            "evaluate": evaluation.check,
            "studio": studio.check,
        }
        if args.command in checks:
            try:
                checks[args.command](args)
            except OptionError as err:
                subcommands(parser)[args.command].error(str(err))
    except SystemExit as exit_:  # argparse's errors (status 2), --help and --version (0)
        return exit_.code if isinstance(exit_.code, int) else 2
    command = {
        "list": _list,
        "validate": _validate,
        "demo": _demo,
        "record": _record,
        "play": keyboard.run,
        "bench": bench_command.run,
        "evaluate": evaluation.run,
        "lifelong": task_streams.run,
        "checkpoint": convert_command.run,
        "studio": studio.run,
    }[args.command]
    try:
        status = command(args)
        sys.stdout.flush()  # here, where a closed pipe can still be caught
        return status
    except BrokenPipeError:  # e.g. ``flatland-ma list | head``: the reader left early
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


def _check_record(args) -> None:
    options.check_world(args)
    if args.out is None:
        try:
            args.out = options.recording(f"{args.scenario}.gif")
        except argparse.ArgumentTypeError as err:
            raise OptionError("--out", str(err)) from None
    frames = args.steps // args.every + 2
    if args.out.suffix.lower() != ".png" and frames > options.MAX_FRAMES:
        raise OptionError(
            "--every",
            f"--steps {args.steps} with --every {args.every} keeps up to {frames:,} frames; "
            f"at most {options.MAX_FRAMES:,} are held (about 1 MB each): keep fewer",
        )


def _list(args) -> int:
    from flatland_ma.envs.registration import gym_id

    for name in list_scenarios():
        spec = load_scenario(name)
        gym = f"  [{gym_id(name, spec.version)}]" if spec.n_agents == 1 else ""
        print(f"{name:28} {spec.n_agents} agent(s)  {spec.description}{gym}")
    return 0


def _validate(args) -> int:
    from flatland_ma.build.feasibility import check_scenario

    failures = 0
    for name in args.files:
        try:
            spec = check_scenario(name)
        except ScenarioError as err:
            failures += 1
            print(f"{name}: INVALID\n{err}")
        except ExtensionError as err:  # a user's kind broke its protocol
            failures += 1
            print(f"{name}: INVALID (an extension's code)\n{err}")
        except ValueError as err:
            failures += 1
            print(f"{name}: {err}")
        else:
            print(
                f"{scenario_path(name)}: ok ({spec.n_agents} agent(s), {len(spec.obstacles)} "
                f"obstacles, {sum(i.n_items for i in spec.items)} items)"
            )
    return 1 if failures else 0


def _demo(args) -> int:
    from flatland_ma.envs.parallel import FlatlandParallelEnv
    from flatland_ma.policies import GreedyForager, RandomPolicy, evaluate

    env = FlatlandParallelEnv("fruits_poisons")
    print(f"fruits_poisons: {env.spec.description}")
    print(f"{args.episodes} episodes of {env.spec.episode.max_steps} steps per policy\n")
    policies = {
        "greedy (scripted)": lambda agent: GreedyForager(
            env.spec, env.possible_agents.index(agent)
        ),
        "random (uniform)": lambda agent: RandomPolicy(env.action_space(agent), seed=0),
    }
    print(f"{'policy':20} {'mean return':>12} {'std':>7} {'fruits':>7} {'poisons':>8}")
    for label, make in policies.items():
        scores = evaluate(env, make, args.episodes)
        fruits = np.mean([i["agent_0"]["fruits"] for i in scores.infos])
        poisons = np.mean([i["agent_0"]["poisons"] for i in scores.infos])
        print(f"{label:20} {scores.mean:>12.1f} {scores.std:>7.1f} {fruits:>7.1f} {poisons:>8.1f}")
    out: Path = args.out
    gif = _write_recording("fruits_poisons", "greedy", 500, 2, 0, out / "fruits_poisons.gif")
    print(f"\nwrote {gif} and {gif.with_suffix('.png')}")
    return 0


def _record(args) -> int:
    try:
        written = _write_recording(
            args.scenario, args.policy, args.steps, args.every, args.seed, args.out,
            options.world_overrides(args),
        )  # fmt: skip
    except ValueError as err:  # a bad override, or a policy the agents cannot follow
        print(f"flatland-ma record: {err}", file=sys.stderr)
        return 2
    print(f"wrote {written}")
    return 0


def _write_recording(scenario, policy, steps, every, seed, out: Path, overrides=None) -> Path:
    from flatland_ma.envs.parallel import FlatlandParallelEnv
    from flatland_ma.policies.named import make_policy
    from flatland_ma.render.video import save_gif, save_mp4, save_png

    env = FlatlandParallelEnv(scenario, render_mode="rgb_array", **(overrides or {}))
    observations, _ = env.reset(seed=seed)
    agents = {a: make_policy(policy, env, a, seed) for a in env.possible_agents}
    video = out.suffix.lower() != ".png"

    def grab() -> np.ndarray:
        frame = env.render()
        assert frame is not None, "an rgb_array env draws a frame"
        return frame

    frames = [grab()]
    for t in range(steps):
        if not env.agents:
            break
        actions = {a: agents[a].act(observations[a]) for a in env.agents}
        observations, *_ = env.step(actions)
        # One frame in ``every``, and always the last (the step that ends the episode).
        last = not env.agents or t == steps - 1
        if video and ((t + 1) % every == 0 or last):
            frames.append(grab())
    if not video:
        return save_png(grab(), out)
    save_png(frames[len(frames) // 2], out.with_suffix(".png"))
    save = save_mp4 if out.suffix.lower() == ".mp4" else save_gif
    return save(frames, out, fps=env.metadata["render_fps"] / every)
