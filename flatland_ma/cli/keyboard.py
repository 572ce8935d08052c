"""``flatland-ma play``: drive one agent with the keyboard (``flatland_ma.play``)."""

from __future__ import annotations

import sys

import flatland_ma.cli.options as options


def add_parser(commands) -> None:
    """``play``: the keyboard game."""
    play = commands.add_parser(
        "play",
        help="play with the keyboard (needs a display)",
        description="Drive one agent with the keyboard; the others follow a policy. "
        "Discrete: up forward, left/right rotate, space stay, q/e head, g/r grasp/release, "
        "z/x arm. Continuous: up/down, a/d and left/right move, the same keys for parts. "
        "Tab: next agent. Esc or closing the window: quit. The world advances while a key "
        "is held; each episode's score is appended to --scores.",
    )
    play.add_argument(
        "scenario",
        nargs="?",
        default="fruits_poisons",
        help="a shipped scenario's name or a scenario file (default: fruits_poisons)",
    )
    play.add_argument(
        "--seed",
        type=options.seed,
        default=None,
        help="the first episode's; episode e plays seed + e (default: random)",
    )
    play.add_argument(
        "--others",
        type=options.policy,
        default=None,
        metavar="POLICY",
        help="the policy of the agents you do not drive: one of "
        f"{', '.join(options.POLICIES)}, or a checkpoint file saved by the baselines "
        "(default: each agent's scenario's reference solver where it suits the agent, else "
        "greedy, sniffer, planner or random, the first that does)",
    )
    play.add_argument(
        "--episodes",
        type=options.positive(options.MAX_EPISODES),
        default=1,
        help="episodes to play (default: 1)",
    )
    _add_output(play)
    options.world_options(play)


def _add_output(play) -> None:
    """``play``'s pace, scores, scripted keys and screenshot."""
    play.add_argument(
        "--scores",
        type=options.output_file(),
        default="play_scores.csv",
        help="CSV that each episode's score is appended to (time, scenario, seed, agent, steps, "
        "score) (default: play_scores.csv)",
    )
    play.add_argument(
        "--fps",
        type=options.number(0.0, options.MAX_FPS, zero="as fast as it goes"),
        default=30.0,
        help="frames (and steps) a second, 0 for as fast as it goes (default: 30)",
    )
    play.add_argument(
        "--keys",
        type=options.key_script,
        default=None,
        metavar="SCRIPT",
        help="keys to press instead of the keyboard, e.g. 'up*20 left*5 tab up*10' (name*N "
        "holds a key N frames, a+b holds two, wait*N holds none); the game ends with the script "
        "(default: none: the keyboard)",
    )
    play.add_argument(
        "--screenshot",
        type=options.output_file(".png"),
        default=None,
        help="a PNG of the window at the end (default: none)",
    )


def run(args) -> int:
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
            overrides=options.world_overrides(args),
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
