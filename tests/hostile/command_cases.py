"""Hostile command lines: options out of range, not finite, too big for the work budget,
paths that cannot be written, names that mean nothing.

Each must be refused when parsed, before any work starts: exit status 2 and the option (or
the file) named on stderr, no traceback. A few legal extremes must simply work (status 0).
``play`` runs on SDL's dummy driver with a key script, so that a case that is not
refused ends by itself.
"""

from __future__ import annotations

from pathlib import Path

from tests.hostile.inputs import Command, Input, command, exits

P = "issue 26: command options"
DUMMY = {"SDL_VIDEODRIVER": "dummy"}
RECORD = ("record", "fruits_poisons", "--steps", "2")
PLAY = ("play", "fruits_poisons", "--keys", "space*2", "--scores", "scores.csv")
BENCH_SCALE = ("bench", "--scale", "--no-ppo", "--seconds", "0.1")


def refused(name: str, argv: tuple[str, ...], *words: str, **options) -> Input:
    """``argv`` exits 2, stderr naming each of ``words`` (the option, or the file)."""
    return Input(name, command(*argv), exits(2, *words), **options)


def play(name: str, extra: tuple[str, ...], *words: str, codes=2, **options) -> Input:
    argv = [*PLAY, *extra]
    return Input(name, lambda folder: Command(argv, DUMMY), exits(codes, *words), **options)


def into_existing_file(argv: tuple[str, ...], option: str):
    """``argv`` with ``option`` naming a file that already exists."""

    def make(folder: Path) -> Command:
        (folder / "taken").write_text("mine\n")
        return Command([*argv, option, "taken"])

    return make


def into_existing_folder(argv: tuple[str, ...], option: str):
    """``argv`` with ``option`` naming a folder."""

    def make(folder: Path) -> Command:
        (folder / "taken").mkdir()
        return Command([*argv, option, "taken"])

    return make


def on_tiny_suite(name: str, argv: tuple[str, ...], *words: str, **options) -> Input:
    """``evaluate ARGV --suite suite.yaml`` on a one-task suite of four-step episodes
    (cheap even when the case is not refused)."""

    def make(folder: Path) -> Command:
        (folder / "suite.yaml").write_text(TINY_SUITE)
        return Command([*argv, "--suite", "suite.yaml", "--out", "out"])

    return Input(name, make, exits(2, *words), **options)


TINY_SUITE = """tasks:
  - scenario: fruits_poisons_multi
    focal: [agent_0]
    background: [idle]
    scripted: [planner]
    episodes: 1
    overrides: {episode: {max_steps: 4}}
"""

RECORD_CASES = [
    refused("record_every_0", (*RECORD, "--every", "0"), "--every"),
    refused("record_every_negative", (*RECORD, "--every", "-3"), "--every"),
    refused("record_steps_negative", ("record", "fruits_poisons", "--steps", "-5"), "--steps"),
    refused("record_steps_zero", ("record", "fruits_poisons", "--steps", "0"), "--steps"),
    refused("record_steps_float", ("record", "fruits_poisons", "--steps", "1e3"), "--steps"),
    refused("record_steps_huge", ("record", "fruits_poisons", "--steps", "9" * 30), "--steps"),
    refused("record_seed_negative", (*RECORD, "--seed", "-1"), "--seed"),
    refused("record_seed_2_to_70", (*RECORD, "--seed", str(2**70)), "--seed"),
    # an output in a missing folder: refused naming it, or written (the folder made)
    Input(
        "record_out_missing_folder",
        command(*RECORD, "--out", "no/such/dir/x.gif"),
        exits((0, 2), "no/such/dir"),
    ),
    refused("record_out_suffix_unknown", (*RECORD, "--out", "x.txt"), "x.txt"),
    Input("record_out_a_folder", into_existing_folder(RECORD, "--out"), exits(2, "taken")),
    refused("record_agents_zero", (*RECORD, "--agents", "0"), "--agents"),
    refused("record_agents_negative", (*RECORD, "--agents", "-2"), "--agents"),
    refused("record_agents_100000", (*RECORD, "--agents", "100000"), "--agents"),
    refused("record_sensors_unknown", (*RECORD, "--sensors", "camera,xray"), "xray"),
    refused("record_policy_unknown", (*RECORD, "--policy", "telepath"), "telepath"),
    refused("record_scenario_unknown", ("record", "fruitz", "--steps", "2"), "fruitz"),
    refused("record_scenario_dev_zero", ("record", "/dev/zero", "--steps", "2"), "/dev/zero"),
    refused("record_scenario_a_folder", ("record", "/tmp", "--steps", "2"), "/tmp"),
    refused("record_option_unknown", (*RECORD, "--fast"), "--fast"),
    Input("record_png_two_steps", command(*RECORD, "--out", "x.png"), exits(0, "x.png")),
]

PLAY_CASES = [
    play("play_fps_negative", ("--fps", "-30"), "--fps"),
    play("play_fps_nan", ("--fps", "nan"), "--fps"),
    play("play_fps_inf", ("--fps", "inf"), "--fps"),
    play("play_episodes_zero", ("--episodes", "0"), "--episodes"),
    play("play_episodes_negative", ("--episodes", "-1"), "--episodes"),
    play("play_keys_held_1e11_frames", ("--keys", "up*99999999999"), "--keys"),
    play("play_keys_unknown", ("--keys", "warp*3"), "warp"),
    play("play_scores_missing_folder", ("--scores", "no/such/dir/s.csv"), codes=(0, 2)),
    play("play_screenshot_missing_folder", ("--screenshot", "no/dir/s.png"), codes=(0, 2)),
    play("play_others_unknown", ("--others", "telepath"), "telepath"),
    play("play_seed_negative", ("--seed", "-5"), "--seed"),
]

BENCH_CASES = [
    refused("bench_steps_negative", ("bench", "--steps", "-1"), "--steps"),
    refused("bench_steps_zero", ("bench", "--steps", "0"), "--steps"),
    refused("bench_scale_worlds_1e8", (*BENCH_SCALE, "--worlds", "1e8"), "--worlds"),
    refused("bench_scale_worlds_10_to_8", (*BENCH_SCALE, "--worlds", "100000000"), "--worlds"),
    refused("bench_scale_worlds_zero", (*BENCH_SCALE, "--worlds", "0"), "--worlds"),
    refused("bench_scale_worlds_empty", (*BENCH_SCALE, "--worlds", ""), "--worlds"),
    refused("bench_scale_seconds_nan", ("bench", "--scale", "--seconds", "nan"), "--seconds"),
    refused("bench_scale_seconds_negative", ("bench", "--scale", "--seconds", "-1"), "--seconds"),
]

EVALUATE = ("evaluate", "random", "--no-plot")
CROSSPLAY = ("evaluate", "--no-plot", "--episodes", "1", "--crossplay")
EVALUATE_CASES = [
    on_tiny_suite("evaluate_episodes_zero", (*EVALUATE, "--episodes", "0"), "--episodes"),
    on_tiny_suite("evaluate_episodes_negative", (*EVALUATE, "--episodes", "-2"), "--episodes"),
    on_tiny_suite("evaluate_seed_negative", (*EVALUATE, "--seed", "-1"), "--seed"),
    on_tiny_suite("evaluate_policy_unknown", ("evaluate", "telepath", "--no-plot"), "telepath"),
    refused("evaluate_no_policy", ("evaluate",), "POLICY"),
    refused("evaluate_suite_unknown", (*EVALUATE, "--suite", "sociology"), "sociology"),
    refused("evaluate_suite_dev_zero", (*EVALUATE, "--suite", "/dev/zero"), "/dev/zero"),
    refused("evaluate_suite_a_folder", (*EVALUATE, "--suite", "/tmp/"), "/tmp"),
    refused("crossplay_one_policy", (*CROSSPLAY, "random"), "--crossplay"),
    refused("crossplay_unknown_policy", (*CROSSPLAY, "random", "telepath"), "telepath"),
    refused(
        "crossplay_scenario_without_teams",
        (*CROSSPLAY, "random", "idle", "--scenario", "fruits_poisons"),
        "fruits_poisons",
    ),
    refused(
        "crossplay_scenario_unknown", (*CROSSPLAY, "random", "idle", "--scenario", "tug"), "tug"
    ),
    Input(
        "evaluate_out_an_existing_file",
        into_existing_file((*CROSSPLAY, "random", "idle"), "--out"),
        exits(2, "taken"),
    ),
]

OTHER_CASES = [
    # demo plays whole episodes and writes a GIF of 500 steps when it is not refused
    refused("demo_episodes_zero", ("demo", "--episodes", "0"), "--episodes", slow=True),
    refused("demo_episodes_negative", ("demo", "--episodes", "-4"), "--episodes", slow=True),
    Input(
        "demo_out_an_existing_file",
        into_existing_file(("demo", "--episodes", "1"), "--out"),
        exits(2, "taken"),
        slow=True,
    ),
    Input("validate_dev_zero", command("validate", "/dev/zero"), exits(1, "/dev/zero")),
    Input("validate_a_folder", command("validate", "/tmp/"), exits(1, "/tmp")),
    Input("validate_missing", command("validate", "no_such.yaml"), exits(1, "no_such.yaml")),
    refused("command_unknown", ("teleport",), "teleport"),
    refused("no_command", (), "command"),
    refused("lifelong_report_no_folder", ("lifelong", "report"), "run_dir"),
]

CASES = [*RECORD_CASES, *PLAY_CASES, *BENCH_CASES, *EVALUATE_CASES, *OTHER_CASES]
