"""Hostile run folders for ``flatland-ma lifelong report``: each fault ends in a
``RunError`` naming the file (and the line and key where there is one), and the command
exits with status 2, never with a traceback, a hang or an OverflowError; the JSON it
writes is strict (no bare NaN)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from flatland_ma.cli import main
from flatland_ma.lifelong.report import RunError, load_run, summarise
from tests.lifelong.test_lifelong_metrics import write_run

ROOT = Path(__file__).resolve().parents[2]


def refuse_constants(token: str):
    raise ValueError(f"not strict JSON: {token}")


def strict_loads(text: str):
    return json.loads(text, parse_constant=refuse_constants)


def refused(run: Path, *words: str) -> str:
    """``load_run(run)`` fails with a RunError holding every one of ``words``, and the
    command exits with 2 naming the same."""
    with pytest.raises(RunError) as caught:
        load_run(run)
    message = str(caught.value)
    for word in words:
        assert word in message, message
    assert main(["lifelong", "report", str(run), "--no-plot"]) == 2
    return message


def rewrite_stream_json(run: Path, **changes) -> Path:
    """``stream.json`` with ``changes``, written one value per line (``indent=1``)."""
    path = run / "stream.json"
    data = json.loads(path.read_text())
    data.update(changes)
    path.write_text(json.dumps(data, indent=1))
    return path


def line_of(path: Path, text: str) -> int:
    """The 1-based line of ``path`` where ``text`` first appears."""
    lines = path.read_text().split("\n")
    return next(i for i, line in enumerate(lines, start=1) if text in line)


# -- stream.json ----------------------------------------------------------------------


@pytest.mark.parametrize(
    "token, key, words",
    [
        ("NaN", "random[1]", "NaN is not a JSON number"),
        ("-Infinity", "random[1]", "-Infinity is not a JSON number"),
        ("1e999", "random[1]", "1e999 is too large"),
        ("1" * 400, "random[1]", "an integer of 400 digits"),
        ("1e13", "random[1]", "less than or equal to 1000000000000"),
    ],
)
def test_numbers_in_stream_json_must_be_finite_and_plausible(tmp_path, token, key, words):
    run = write_run(tmp_path / "run", seeds=(0,))
    path = rewrite_stream_json(run, random=[0.0, 12345.5, 0.0])
    path.write_text(path.read_text().replace("12345.5", token))
    line = line_of(path, token)
    refused(run, f"{path}:{line}: {key}: ", words)


def test_a_huge_integer_in_the_segments_is_refused_at_its_key(tmp_path):
    run = write_run(tmp_path / "run", seeds=(0,))
    path = rewrite_stream_json(run, segments=[[0, 0, 100], [1, 100, 777], [2, 200, 300]])
    path.write_text(path.read_text().replace("777", "9" * 400))
    refused(run, f"{path}:{line_of(path, '9' * 400)}: segments[1][2]: an integer of 400")
    rewrite_stream_json(run, segments=[[0, 0, 100], [1, 100, 10**15], [2, 200, 300]])
    refused(run, "segments[1][2]: ", "less than or equal to")


def test_segments_that_go_backwards_or_name_no_task_are_refused(tmp_path):
    run = write_run(tmp_path / "run", seeds=(0,))
    path = rewrite_stream_json(run, segments=[[0, 0, 100], [1, 50, 200], [2, 200, 300]])
    refused(run, f"{path}:", "segments[1]: [50, 200) after a segment ending at 100")
    rewrite_stream_json(run, segments=[[0, 0, 100], [5, 100, 200], [2, 200, 300]])
    refused(run, "segments[1][0]: task 5, of 3 tasks")
    rewrite_stream_json(run, random=[0, 0])
    refused(run, "random: 2 returns for 3 tasks")


def test_stream_json_unknown_keys_duplicates_and_bad_text_are_located(tmp_path):
    run = write_run(tmp_path / "run", seeds=(0,))
    path = rewrite_stream_json(run, bogus=1)
    refused(run, f"{path}:{line_of(path, 'bogus')}: bogus:")
    path.write_text('{"tasks": ["a"],\n "tasks": ["b"]}')
    refused(run, f"{path}:2: tasks: key given twice")
    path.write_text('{"tasks": ["a"],\n "random": [1, 2,]}')
    refused(run, f"{path}:2: random[2]: not JSON")
    path.write_bytes(b'{"stream": "caf\xe9"}')
    refused(run, f"{path}:1: not UTF-8")
    path.write_text("[]")
    refused(run, f"{path}:1: expected an object")
    path.unlink()
    refused(run, f"{path}: no such file")


# -- evaluations.csv -------------------------------------------------------------------


def evaluations(run: Path, method: str = "finetune") -> Path:
    return run / method / "seed_0" / "evaluations.csv"


@pytest.mark.parametrize(
    "old, new, words",
    [
        ("100,1,1,2.0", "100,1,1,1e999", ":6: return inf: not a finite number"),
        ("100,1,1,2.0", "100,1,1,nan", ":6: expected step,task,episodes,mean_return"),
        ("100,1,1,2.0", "100,1,1,-2e13", ":6: return -2e+13: not a finite number within"),
        ("100,1,1,2.0", "1" + "0" * 399 + ",1,1,2.0", ":6: expected step,task,episodes"),
        ("100,1,1,2.0", "100,1,1,2.0," + "7" * 200_000, ":6: expected step,task,episodes"),
        ("100,1,1,2.0", "100,1,1," + "7" * 200_000, "(200,000 characters)"),
        ("100,1,1,2.0", "100,1,0,2.0", ":6: 0 episodes"),
        ("100,1,1,2.0", "100,1,1", ":6: expected step,task,episodes,mean_return: 3 fields"),
    ],
)
def test_numbers_in_evaluation_tables_must_be_finite_and_plausible(tmp_path, old, new, words):
    run = write_run(tmp_path / "run", seeds=(0,))
    path = evaluations(run)
    path.write_text(path.read_text().replace(f"\n{old}\n", f"\n{new}\n"))
    assert new in path.read_text()
    message = refused(run, str(path), words)
    assert len(message) < 1000  # the 200,000 characters are not echoed back


def test_evaluation_steps_that_go_backwards_are_refused_at_their_line(tmp_path):
    run = write_run(tmp_path / "run", seeds=(0,))
    path = evaluations(run)
    text = path.read_text()
    path.write_text(text.replace("\n200,", "\n50,"))  # the third block, before the second
    refused(run, f"{path}:8: block 2 at step 50, after step 100", "go backwards")
    path.write_text(text)
    reference = evaluations(run, "reference")
    rows = reference.read_text().split("\n")
    rows[2], rows[3] = rows[3], rows[2]  # task 0's steps 0, 100, then 50 (on line 4)
    reference.write_text("\n".join(rows))
    refused(run, f"{reference}:4: task 0 at step 50, after step 100", "go backwards")


def test_evaluation_tables_that_are_not_utf8_are_refused_with_file_and_line(tmp_path):
    run = write_run(tmp_path / "run", seeds=(0,))
    path = evaluations(run)
    path.write_bytes(path.read_bytes().replace(b"\n100,1,1,2.0\n", b"\n100,1,1,2.\xff\n"))
    refused(run, f"{path}:6: not UTF-8 text")


def test_a_seed_folder_not_named_by_a_number_is_named_in_the_error(tmp_path):
    run = write_run(tmp_path / "run", seeds=(0,))
    (run / "finetune" / "seed_0").rename(run / "finetune" / "seed_x")
    refused(run, f"{run / 'finetune' / 'seed_x'}: a seed's folder is named seed_<number>")


# -- what belongs to be a file is not one ------------------------------------------------

SPECIAL_FILES = """
import json, sys
from flatland_ma.lifelong.report import RunError, load_run
out = {}
for run in sys.argv[1:]:
    try:
        load_run(run)
        out[run] = "loaded"
    except RunError as err:
        out[run] = str(err)
print(json.dumps(out))
"""


def special(tmp_path: Path, name: str, target: str, make) -> tuple[Path, Path]:
    """A run folder whose ``target`` (``stream.json`` or the evaluation table) is made by
    ``make(path)`` instead of being a file."""
    run = write_run(tmp_path / name, seeds=(0,))
    path = run / "stream.json" if target == "stream" else evaluations(run)
    path.unlink()
    make(path)
    return run, path


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_folders_fifos_devices_and_link_loops_where_a_file_belongs_are_refused(tmp_path):
    """Run in a child process (a regression would hang on the FIFO or fill the memory from
    /dev/zero): each must end, promptly and within the limit, in a RunError naming it."""

    def loop(path: Path) -> None:
        os.symlink(path.name + ".other", path)
        os.symlink(path.name, str(path) + ".other")

    makers = {
        "folder": (lambda p: p.mkdir(), "a directory"),
        "fifo": (lambda p: os.mkfifo(p), "a FIFO"),
        "zero": (lambda p: os.symlink("/dev/zero", p), "a device"),
        "loop": (loop, "a loop of symbolic links"),
    }
    cases = {}
    for kind, (make, words) in makers.items():
        for target in ("stream", "table"):
            run, path = special(tmp_path, f"{kind}_{target}", target, make)
            cases[str(run)] = (str(path), words)
    done = subprocess.run(
        [sys.executable, "-c", SPECIAL_FILES, *cases],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,  # a hang is a failure; the reads themselves take milliseconds
    )
    assert done.returncode == 0, done.stderr
    results = json.loads(done.stdout)
    for run, (path, words) in cases.items():
        assert results[run].startswith(f"{path}: {words}"), (run, results[run])


# -- the JSON written ------------------------------------------------------------------


def test_the_report_json_is_strict_with_null_for_undefined_metrics(tmp_path, capsys):
    run = write_run(tmp_path / "run", seeds=(0,))  # one seed: no interval; last task: no F
    assert main(["lifelong", "report", str(run), "--no-plot", "--json"]) == 0
    printed = capsys.readouterr().out
    written = (run / "lifelong.json").read_text()
    assert "NaN" not in written and "Infinity" not in written
    data = strict_loads(written)
    assert strict_loads(printed) == data
    aggregate = data["methods"]["finetune"]["aggregate"]
    assert aggregate["average"][0] == pytest.approx(0.5) and aggregate["average"][1:] == [
        None,
        None,
    ]
    assert data["methods"]["finetune"]["seeds"][0]["forgetting"][2] is None
    assert summarise(load_run(run))["tasks"] == data["tasks"]


def test_the_shipped_reports_are_strict_json():
    paths = sorted((ROOT / "docs" / "lifelong").glob("*/lifelong.json"))
    assert len(paths) >= 2
    for path in paths:
        data = strict_loads(path.read_text())
        assert data["methods"] and len(data["random"]) == len(data["tasks"])
