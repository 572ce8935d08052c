"""Every option of every command is checked when the command line is parsed: a wrong one
stops with status 2 and a message naming it, with no traceback, before any work starts
(nothing is run, nothing is written)."""

import argparse
import re
from pathlib import Path

import pytest

from flatland_ma.cli import bench as bench_command
from flatland_ma.cli import commands as cli
from flatland_ma.cli import evaluate as evaluation
from flatland_ma.cli import keyboard
from flatland_ma.cli import task_streams as lifelong
from flatland_ma.cli.options import MAX_FRAMES
from flatland_ma.play.keys import MAX_SCRIPT_FRAMES, Keys, ScriptedKeys, parse_script


@pytest.fixture
def no_work(monkeypatch, tmp_path):
    """Every command's work replaced by a recorder, in an empty working folder: a refused
    command line must reach none of them and write nothing."""
    ran = []

    def runner(name):
        def run(args):
            ran.append(name)
            return 0

        return run

    for name in ("_list", "_validate", "_demo", "_record"):
        monkeypatch.setattr(cli, name, runner(name))
    monkeypatch.setattr(keyboard, "run", runner("_play"))
    monkeypatch.setattr(bench_command, "run", runner("bench"))
    monkeypatch.setattr(evaluation, "run", runner("evaluate"))
    monkeypatch.setattr(lifelong, "run", runner("lifelong"))
    monkeypatch.chdir(tmp_path)
    return ran


def refused(capsys, argv, option, ran, *more):
    """``argv`` exits with 2, naming ``option`` (and each of ``more``) in one message, no
    traceback, nothing run or written."""
    before = {p.name for p in Path.cwd().iterdir()}
    assert cli.main(argv) == 2, argv
    err = capsys.readouterr().err
    assert f"argument {option}:" in err, err
    for text in more:
        assert text in err, err
    assert "Traceback" not in err and "internal error" not in err
    assert ran == []
    assert {p.name for p in Path.cwd().iterdir()} == before
    return err


@pytest.mark.parametrize(
    "argv, option, said",
    [
        (["record", "fruits_poisons", "--every", "0"], "--every", "from 1"),
        (["record", "fruits_poisons", "--steps", "-5"], "--steps", "'-5'"),
        (["record", "fruits_poisons", "--steps", "1e3"], "--steps", "'1e3'"),
        (["record", "fruits_poisons", "--seed", "-1"], "--seed", "from 0"),
        (["record", "fruits_poisons", "--policy", "nobody"], "--policy", "no policy 'nobody'"),
        (["record", "fruits_poisons", "--policy", "gone.pt"], "--policy", "not a file"),
        (["record", "fruits_poisons", "--out", "clip.jpg"], "--out", ".gif"),
        (["record", "no_such_scenario"], "scenario", "unknown scenario"),
        (["record", "fruits_poisons", "--agents", "0"], "--agents", "'0'"),
        (["record", "fruits_poisons", "--agents", "65"], "--agents", "n_agents"),
        (["record", "fruits_poisons", "--sensors", "sonar"], "--sensors", "sonar"),
        (["record", "fruits_poisons", "--sensors", ","], "--sensors", "names"),
        (["play", "--steps", "5"], "", "unrecognized arguments"),
        (["play", "--fps", "-30"], "--fps", "'-30'"),
        (["play", "--fps", "nan"], "--fps", "finite"),
        (["play", "--fps", "inf"], "--fps", "finite"),
        (["play", "--episodes", "0"], "--episodes", "from 1"),
        (["play", "--seed", "99999999999"], "--seed", "a seed"),
        (["play", "--others", "nobody"], "--others", "no policy"),
        (["play", "--keys", "up*999999999999"], "--keys", f"at most {MAX_SCRIPT_FRAMES:,}"),
        (["play", "--keys", "up*0"], "--keys", "fewer than one frame"),
        (["play", "--keys", "up*x"], "--keys", "number of frames"),
        (["play", "--keys", "jump*3"], "--keys", "no key 'jump'"),
        (["play", "--screenshot", "end.jpg"], "--screenshot", ".png"),
        (["play", "--agents", "100"], "--agents", "n_agents"),
        (["demo", "--episodes", "0"], "--episodes", "from 1"),
        (["demo", "--episodes", "-3"], "--episodes", "'-3'"),
        (["bench", "--steps", "-1"], "--steps", "'-1'"),
        (["bench", "--steps", "0"], "--steps", "from 1"),
        (["bench", "--steps", "10000000000"], "--steps", "200,000"),
        (["bench", "--worlds", "4"], "--worlds", "only with --scale"),
        (["bench", "--no-ppo"], "--no-ppo", "only with --scale"),
        (["bench", "--scale", "--steps", "10"], "--steps", "not with --scale"),
        (["bench", "--scale", "--worlds", "0"], "--worlds", "'0'"),
        (["bench", "--scale", "--worlds", "1e8"], "--worlds", "'1e8'"),
        (["bench", "--scale", "--worlds", "1,,4"], "--worlds", "positive"),
        (["bench", "--scale", "--worlds", "100000000"], "--worlds", "work budget"),
        (["bench", "--scale", "--seconds", "nan"], "--seconds", "finite"),
        (["bench", "--scale", "--seconds", "0"], "--seconds", "above 0"),
        (["evaluate", "greedy", "--episodes", "0"], "--episodes", "from 1"),
        (["evaluate", "greedy", "--seed", "-2"], "--seed", "from 0"),
        (["evaluate", "greedy", "--suite", "nosuite"], "--suite", "no suite"),
        (["evaluate", "nobody"], "policy", "no policy"),
        (["evaluate"], "policy", "give a POLICY"),
        (["evaluate", "greedy", "--scenario", "tug_of_war"], "--scenario", "only with"),
        (["evaluate", "--crossplay", "greedy"], "--crossplay", "two or more"),
        (["evaluate", "--crossplay", "greedy", "greedy"], "--crossplay", "different"),
        (["evaluate", "--crossplay", "greedy", "nobody"], "--crossplay", "no policy 'nobody'"),
        (
            ["evaluate", "--crossplay", "greedy", "random", "--scenario", "fruits_poisons"],
            "--scenario",
            "two teams",
        ),
        (
            ["evaluate", "--crossplay", "greedy", "random", "--scenario", "nowhere"],
            "--scenario",
            "unknown scenario",
        ),
        (["evaluate", "greedy", "--crossplay", "greedy", "random"], "policy", "not with"),
        (["lifelong", "report", "no_such_run"], "run_dir", "does not exist"),
    ],
)
def test_a_wrong_option_exits_2_naming_it_before_any_work(capsys, no_work, argv, option, said):
    if option:
        refused(capsys, argv, option, no_work, said)
    else:  # an option the command does not have: argparse's own refusal
        assert cli.main(argv) == 2
        assert said in capsys.readouterr().err and no_work == []


def test_a_recording_too_long_to_hold_is_refused_naming_every(capsys, no_work):
    steps = str(MAX_FRAMES * 3)
    err = refused(
        capsys,
        ["record", "fruits_poisons", "--steps", steps, "--every", "1"],
        "--every",
        no_work,
        "frames",
    )
    assert "--steps" in err
    # Only a PNG (the last frame) holds one frame, however long the play.
    assert cli.main(["record", "fruits_poisons", "--steps", steps, "--out", "a.png"]) == 0
    assert no_work == ["_record"]


def test_output_paths_where_a_file_or_a_folder_stands_in_the_way(capsys, no_work, tmp_path):
    (tmp_path / "taken").write_text("a file")
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "lifelong.json").write_text("{}")
    before = (tmp_path / "taken").read_text()
    cases = [
        (["record", "fruits_poisons", "--out", "taken/clip.gif"], "--out", "is a file"),
        (["record", "fruits_poisons", "--out", "run.gif/"], "--out", None),
        (["demo", "--out", "taken"], "--out", "a folder is wanted"),
        (["play", "--scores", "run"], "--scores", "a file is wanted"),
        (["play", "--scores", "taken/scores.csv"], "--scores", "is a file"),
        (["evaluate", "greedy", "--out", "taken"], "--out", "a folder is wanted"),
        (["lifelong", "report", "run", "--out", "taken"], "--out", "a folder is wanted"),
        (["lifelong", "report", "run", "--out", "run/lifelong.json"], "--out", "is a file"),
        (["lifelong", "report", "taken"], "run_dir", "not a folder"),
    ]
    (tmp_path / "run.gif").mkdir()
    for argv, option, said in cases:
        refused(capsys, argv, option, no_work, *([said] if said else []))
    assert (tmp_path / "taken").read_text() == before


def test_a_default_output_path_is_checked_like_a_given_one(capsys, no_work, tmp_path):
    (tmp_path / "fruits_poisons.gif").mkdir()  # where record writes by default
    refused(capsys, ["record", "fruits_poisons"], "--out", no_work, "a file is wanted")
    (tmp_path / "runs").write_text("not a folder")  # evaluate's default is under runs/
    refused(capsys, ["evaluate", "greedy"], "--out", no_work, "(default)")


def test_an_output_file_needs_its_folder_and_an_output_folder_is_made(capsys, no_work):
    for argv, option in (
        (["record", "fruits_poisons", "--out", "no/such/clip.gif"], "--out"),
        (["play", "--scores", "no/such/scores.csv"], "--scores"),
        (["play", "--screenshot", "no/such/end.png"], "--screenshot"),
    ):
        refused(capsys, argv, option, no_work, "the folder 'no/such' does not exist")
    # A folder is made where it is missing (when the command writes into it).
    assert cli.main(["evaluate", "greedy", "--out", "new/deeper"]) == 0
    assert cli.main(["lifelong", "report", ".", "--out", "new/deeper"]) == 0
    assert no_work == ["evaluate", "lifelong"]


def test_right_options_reach_the_command_as_checked_values(no_work, monkeypatch):
    argv = ["record", "fruits_poisons", "--steps", "7", "--every", "3", "--seed", "4294967295"]
    assert cli.main([*argv, "--agents", "2", "--sensors", "camera,lidar"]) == 0
    parsed = {}
    monkeypatch.setattr(cli, "_record", lambda args: parsed.update(vars(args)) or 0)
    assert cli.main([*argv, "--agents", "2", "--sensors", "camera,lidar"]) == 0
    assert parsed["steps"] == 7 and parsed["every"] == 3 and parsed["seed"] == 2**32 - 1
    assert parsed["agents"] == 2 and parsed["sensors"] == ["camera", "lidar"]
    assert str(parsed["out"]) == "fruits_poisons.gif"  # the default, checked
    assert cli.main(["play", "--fps", "0", "--keys", "up*3 wait*2 left+up"]) == 0  # 0: no wait
    assert cli.main(["bench", "--scale", "--worlds", "1,16", "--seconds", "0.5"]) == 0
    assert cli.main(["evaluate", "--crossplay", "greedy", "random"]) == 0
    assert cli.main(["evaluate", "--list"]) == 0
    assert no_work == ["_record", "_play", "bench", "evaluate", "evaluate"]


def test_a_key_script_is_checked_whole_and_played_without_expanding_it():
    runs = parse_script("up*1000000")
    assert runs == [(frozenset({"up"}), 1_000_000)]  # one run, not a million frames
    keys = ScriptedKeys("up*400000 tab wait*599999")  # the most frames a script may have
    assert len(keys.runs) == 3
    first = keys.poll([])
    assert first == Keys(frozenset({"up"}), frozenset({"up"}))
    assert all(keys.poll([]) == Keys(held=frozenset({"up"})) for _ in range(399_999))
    assert keys.poll([]).pressed == {"tab"}
    with pytest.raises(ValueError, match="at most"):
        parse_script("up*600000 left*400001")
    with pytest.raises(ValueError, match="no key"):
        parse_script("up+jump")


def all_parsers(parser: argparse.ArgumentParser, name: str = "flatland-ma"):
    """Every parser under ``parser`` (itself, each command, each command's commands)."""
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, child in action.choices.items():
                yield from all_parsers(child, f"{name} {sub}")


def test_the_help_lists_every_command_without_marks(capsys):
    assert cli.main(["--help"]) == 0
    out = capsys.readouterr().out
    commands = cli.subcommands(cli.build_parser())
    assert {"list", "validate", "demo", "record", "play", "bench", "evaluate", "lifelong"} <= set(
        commands
    )
    listed = out.split("positional arguments:")[1]
    for name in commands:
        assert re.search(rf"\n    {name}\s", listed), name
    assert "``" not in out and "%%" not in out and ":ref:" not in out


def test_every_option_has_help_and_no_help_shows_doubled_percent_or_rst(capsys):
    for name, parser in all_parsers(cli.build_parser()):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                helps = [a.help for a in action._choices_actions]
                assert len(helps) == len(action.choices) and all(helps), name
            else:
                assert action.help and action.help != argparse.SUPPRESS, (name, action.dest)
        text = parser.format_help()
        assert "%%" not in text and "``" not in text, name
    for command in (["evaluate", "--help"], ["lifelong", "--help"]):
        assert cli.main(command) == 0
        out = capsys.readouterr().out
        assert "95%" in out and "95%%" not in out
    assert cli.main(["bench", "--help"]) == 0
    assert re.search(r"--steps STEPS\s+env steps timed per row", capsys.readouterr().out)


def test_play_from_python_refuses_a_pace_or_a_count_that_cannot_end(monkeypatch):
    import flatland_ma.envs.parallel as parallel
    from flatland_ma.play import play

    def no_world(*args, **kwargs):
        raise AssertionError("a world was built")

    monkeypatch.setattr(parallel, "FlatlandParallelEnv", no_world)
    for fps in (float("nan"), float("inf"), -30.0, "30"):
        with pytest.raises(ValueError, match="fps"):
            play("fruits_poisons", fps=fps, script="up")  # type: ignore[arg-type]
    for episodes in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="episodes"):
            play("fruits_poisons", episodes=episodes, script="up")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="at most"):
        play("fruits_poisons", script="up*999999999999")
