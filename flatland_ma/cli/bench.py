"""``flatland-ma bench``: each env's rate beside the bare ``space.step`` rate of its world,
and what each sensor kind costs; or, with ``--scale``, the batched env over many worlds
(``flatland_ma.bench.throughput`` and ``flatland_ma.bench.scale`` measure)."""

from __future__ import annotations

import json

import flatland_ma.cli.options as options
from flatland_ma.cli.options import OptionError

STEPS = 20_000
"""``--steps`` when not given."""
SCALE_ONLY = ("--worlds", "--seconds", "--no-ppo")


def add_parser(commands) -> None:
    bench = commands.add_parser(
        "bench",
        help="steps per second beside bare space.step",
        description="The rate of each env (Gymnasium, PettingZoo parallel, batched) beside "
        "the bare space.step rate of its world, and what each sensor kind costs. With "
        "--scale: the batched env over many worlds instead.",
    )
    bench.add_argument(
        "--steps",
        type=options.positive(options.MAX_BENCH_STEPS),
        default=None,
        help=f"env steps timed per row (default: {STEPS}; not with --scale)",
    )
    bench.add_argument("--json", action="store_true", help="print the figures as JSON")
    bench.add_argument(
        "--scale",
        action="store_true",
        help="instead: the batched env over many worlds, one process and every core, and PPO "
        "end to end (a few minutes)",
    )
    bench.add_argument(
        "--worlds",
        type=options.worlds,
        default=None,
        help="with --scale: the numbers of worlds, comma-separated, each within the work "
        "budget (default: 1,16,256,1024)",
    )
    bench.add_argument(
        "--seconds",
        type=options.number(0.0, options.MAX_BENCH_SECONDS),
        default=None,
        help="with --scale: seconds per row (default: 3)",
    )
    bench.add_argument("--no-ppo", action="store_true", help="with --scale: skip PPO")


def check(args) -> None:
    """``OptionError`` for an option of the other mode, or a row of worlds over the work
    budget (``bench_scale.check_worlds``)."""
    if not args.scale:
        for option in SCALE_ONLY:
            if getattr(args, option[2:].replace("-", "_")):
                raise OptionError(option, "only with --scale")
        return
    if args.steps is not None:
        raise OptionError("--steps", "not with --scale (its rows run for --seconds)")
    from flatland_ma.bench import scale as bench_scale

    try:
        bench_scale.check_worlds(args.worlds or bench_scale.WORLDS)
    except ValueError as err:
        raise OptionError("--worlds", str(err)) from None


def _tier() -> str:
    """The physics bridge's tier in use (``flatland_ma.world.physics``)."""
    from flatland_ma.world import physics

    return physics.describe()


def run(args) -> int:
    if args.scale:
        return _scale(args)
    from flatland_ma.bench.sensors import format_costs, sensor_costs
    from flatland_ma.bench.throughput import format_table
    from flatland_ma.bench.throughput import run as bench

    steps = args.steps or STEPS
    results = bench(steps)
    costs = sensor_costs(max(100, steps // 4))
    if args.json:
        envs = [
            {
                "environment": r.label,
                "agents": r.agents,
                "env_steps_per_s": r.env_steps_per_s,
                "agent_steps_per_s": r.agent_steps_per_s,
                "bare_space_step_per_s": r.bare_steps_per_s,
                **r.machine(),
            }
            for r in results
        ]
        sensing = [{"setup": c.label, "us_per_agent_step": c.micros_per_agent_step} for c in costs]
        figures = {"steps": steps, "physics_tier": _tier(), "environments": envs}
        print(json.dumps({**figures, "sensing": sensing}, indent=1))
        return 0
    print(f"physics tier: {_tier()}")
    print(format_table(results))
    print()
    print(format_costs(costs))
    return 0


def _scale(args) -> int:
    from flatland_ma.bench import scale as bench_scale

    worlds = args.worlds or bench_scale.WORLDS
    seconds = args.seconds or bench_scale.SECONDS
    scale = bench_scale.run(worlds, seconds, not args.no_ppo)
    if args.json:
        print(json.dumps({"physics_tier": _tier(), **bench_scale.as_json(scale)}, indent=1))
    else:
        print(f"physics tier: {_tier()}")
        print(bench_scale.format_table(scale))
    return 0
