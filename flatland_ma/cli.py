"""The ``flatland-ma`` command: list | validate | demo | record | play | bench."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

from flatland_ma import __version__
from flatland_ma.evaluation import command as evaluation
from flatland_ma.lifelong import command as lifelong
from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import list_scenarios, load_scenario, scenario_path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="flatland-ma", description=__doc__)
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)

    commands.add_parser("list", help="the shipped scenarios, one line each")

    validate = commands.add_parser("validate", help="check scenario files")
    validate.add_argument("files", nargs="+", help="scenario files or shipped names")

    demo = commands.add_parser("demo", help="greedy and random play on fruits_poisons")
    demo.add_argument("--episodes", type=int, default=10)
    demo.add_argument("--out", default="demo", help="folder for the GIF and the PNG")

    record = commands.add_parser(
        "record",
        help="write a GIF or an MP4 (and a PNG of its middle frame), or only a PNG, of play",
    )
    record.add_argument("scenario")
    record.add_argument(
        "--policy",
        default="greedy",
        metavar="POLICY",
        help="greedy, planner, carrier, sniffer, random, or the path of a checkpoint saved by "
        "the baselines (e.g. runs/ppo/fruits_poisons/seed_0.pt) (default: greedy)",
    )
    record.add_argument("--steps", type=int, default=300)
    record.add_argument("--every", type=int, default=2, help="keep one frame in this many")
    record.add_argument("--seed", type=int, default=0)
    record.add_argument(
        "--out",
        default=None,
        help="a .gif or .mp4, or a .png for the last frame only (default: <scenario>.gif)",
    )
    _world_options(record)

    play = commands.add_parser(
        "play",
        help="play with the keyboard (needs a display)",
        description="Drive one agent with the keyboard; the others follow a policy. "
        "Discrete: up forward, left/right rotate, space stay, q/e head, g/r grasp/release, "
        "z/x arm. Continuous: up/down, a/d and left/right move, the same keys for parts. "
        "Tab: next agent. Esc or closing the window: quit. The world advances while a key "
        "is held; each episode's score is appended to --scores.",
    )
    play.add_argument("scenario", nargs="?", default="fruits_poisons")
    play.add_argument(
        "--seed", type=int, default=None, help="the first episode's (default: random)"
    )
    play.add_argument(
        "--others",
        default="greedy",
        metavar="POLICY",
        help="the policy of the agents you do not drive: greedy, random, planner, carrier, "
        "sniffer, idle, or a checkpoint file saved by the baselines (default: greedy)",
    )
    play.add_argument("--episodes", type=int, default=1)
    play.add_argument(
        "--scores",
        default="play_scores.csv",
        help="CSV that each episode's score is appended to (time, scenario, seed, agent, steps, "
        "score)",
    )
    play.add_argument("--fps", type=float, default=30.0, help="frames (and steps) a second")
    play.add_argument(
        "--keys",
        default=None,
        metavar="SCRIPT",
        help="keys to press instead of the keyboard, e.g. 'up*20 left*5 tab up*10' (name*N "
        "holds a key N frames, a+b holds two); the game ends with the script",
    )
    play.add_argument("--screenshot", default=None, help="a PNG of the window at the end")
    _world_options(play)

    bench = commands.add_parser("bench", help="steps per second beside bare space.step")
    bench.add_argument("--steps", type=int, default=20_000)
    bench.add_argument("--json", action="store_true", help="print the figures as JSON")
    bench.add_argument(
        "--scale",
        action="store_true",
        help="instead: the batched env over many worlds, one process and every core, and PPO "
        "end to end (a few minutes)",
    )
    bench.add_argument(
        "--worlds",
        default="1,16,256,1024",
        help="with --scale: the numbers of worlds, comma-separated (default: 1,16,256,1024)",
    )
    bench.add_argument("--seconds", type=float, default=3.0, help="with --scale: per row")
    bench.add_argument("--no-ppo", action="store_true", help="with --scale: skip PPO")

    evaluation.add_parser(commands)
    lifelong.add_parser(commands)

    args = parser.parse_args(argv)
    command = {
        "list": _list,
        "validate": _validate,
        "demo": _demo,
        "record": _record,
        "play": _play,
        "bench": _bench,
        "evaluate": evaluation.run,
        "lifelong": lifelong.run,
    }[args.command]
    try:
        status = command(args)
        sys.stdout.flush()  # here, where a closed pipe can still be caught
        return status
    except BrokenPipeError:  # e.g. ``flatland-ma list | head``: the reader left early
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


def _world_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--agents", type=int, default=None, help="number of agents (n_agents)")
    parser.add_argument(
        "--sensors",
        default=None,
        metavar="TYPES",
        help="each agent's sensors, by type with their defaults, e.g. camera,lidar,proprioception",
    )


def _overrides(args) -> dict:
    """The scenario keys ``--agents`` and ``--sensors`` set."""
    overrides: dict = {}
    if args.agents is not None:
        overrides["n_agents"] = args.agents
    if args.sensors:
        overrides["agent"] = {"sensors": [{"type": t} for t in args.sensors.split(",") if t]}
    return overrides


def _list(args) -> int:
    from flatland_ma.registration import gym_id

    for name in list_scenarios():
        spec = load_scenario(name)
        gym = f"  [{gym_id(name)}]" if spec.n_agents == 1 else ""
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
    out = Path(args.out)
    gif = _write_recording("fruits_poisons", "greedy", 500, 2, 0, out / "fruits_poisons.gif")
    print(f"\nwrote {gif} and {gif.with_suffix('.png')}")
    return 0


def _record(args) -> int:
    from flatland_ma.render.video import check_writable

    out = Path(args.out or f"{args.scenario}.gif")
    try:
        check_writable(out)
    except ValueError as err:
        print(f"flatland-ma record: {err}", file=sys.stderr)
        return 2
    try:
        written = _write_recording(
            args.scenario, args.policy, args.steps, args.every, args.seed, out, _overrides(args)
        )
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


def _play(args) -> int:
    from flatland_ma.play import missing_display

    problem = missing_display()
    if problem is not None:  # before pygame or the world: nothing to wait for
        print(problem, file=sys.stderr)
        return 2
    from flatland_ma.play import play

    try:
        session = play(
            args.scenario,
            seed=args.seed,
            others=args.others,
            episodes=args.episodes,
            scores=args.scores,
            fps=args.fps,
            script=args.keys,
            screenshot=args.screenshot,
            overrides=_overrides(args),
        )
    except ValueError as err:  # a bad override, a bad key script, a policy that cannot run
        print(f"flatland-ma play: {err}", file=sys.stderr)
        return 2
    for row in session.finished:
        seed, agent, score, steps = (row[k] for k in ("seed", "agent", "score", "steps"))
        print(f"episode seed {seed}: {agent} scored {score} in {steps} steps")
    if session.finished and args.scores:
        print(f"scores appended to {args.scores}")
    if session.stopped and session.tallies:
        print("left before the episode ended: its score is not written")
    return 0


def _bench(args) -> int:
    from flatland_ma.bench import format_table, run
    from flatland_ma.bench_sensors import format_costs, sensor_costs

    if args.scale:
        return _bench_scale(args)
    results = run(args.steps)
    costs = sensor_costs(max(100, args.steps // 4))
    if args.json:
        import json

        envs = [
            {
                "environment": r.label,
                "agents": r.agents,
                "env_steps_per_s": r.env_steps_per_s,
                "agent_steps_per_s": r.agent_steps_per_s,
                "bare_space_step_per_s": r.bare_steps_per_s,
            }
            for r in results
        ]
        sensing = [{"setup": c.label, "us_per_agent_step": c.micros_per_agent_step} for c in costs]
        print(json.dumps({"steps": args.steps, "environments": envs, "sensing": sensing}, indent=1))
        return 0
    print(format_table(results))
    print()
    print(format_costs(costs))
    return 0


def _bench_scale(args) -> int:
    from flatland_ma import bench_scale

    try:
        worlds = tuple(int(n) for n in args.worlds.split(","))
        if any(n < 1 for n in worlds):
            raise ValueError
    except ValueError:
        print(f"flatland-ma bench: --worlds {args.worlds!r}: positive integers", file=sys.stderr)
        return 2
    results, training = bench_scale.run(worlds, args.seconds, not args.no_ppo)
    if args.json:
        import json

        print(json.dumps(bench_scale.as_json(results, training), indent=1))
    else:
        print(bench_scale.format_table(results, training))
    return 0


if __name__ == "__main__":
    sys.exit(main())
