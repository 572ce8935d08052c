"""The one door files come in by (``flatland_ma.scenario.files``) and the strict JSON
reader with lines (``flatland_ma.scenario.json_reader``)."""

from __future__ import annotations

import json
import os

import pytest

from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.files import check_regular_file, read_bytes, read_text
from flatland_ma.scenario.json_reader import MAX_DEPTH, parse_json
from flatland_ma.scenario.loader import load_scenario


def test_a_regular_file_is_read_whole_within_its_limit(tmp_path):
    path = tmp_path / "f.txt"
    path.write_bytes(b"x" * 100)
    assert read_bytes(path, limit=100) == b"x" * 100
    with pytest.raises(ScenarioError, match=r"f.txt: 101 bytes: larger than the 100 allowed"):
        path.write_bytes(b"x" * 101)
        read_bytes(path, limit=100)
    assert check_regular_file(path) == path


def test_text_that_is_not_utf8_is_refused_at_its_line(tmp_path):
    path = tmp_path / "f.txt"
    path.write_bytes(b"one\ntwo\nth\xffree\n")
    with pytest.raises(ScenarioError) as caught:
        read_text(path)
    problem = caught.value.problems[0]
    assert (problem.source, problem.line) == (str(path), 3) and "not UTF-8" in problem.message


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_what_is_not_a_regular_file_is_refused_without_reading_it(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)  # no writer: a blocking open would wait for ever
    os.symlink("loop_b", tmp_path / "loop_a")
    os.symlink("loop_a", tmp_path / "loop_b")
    cases = {
        fifo: "a FIFO",
        tmp_path: "a directory",
        "/dev/zero": "a device",
        tmp_path / "loop_a": "a loop of symbolic links",
        tmp_path / "missing": "no such file",
    }
    for path, words in cases.items():
        for read in (read_bytes, read_text, check_regular_file):
            with pytest.raises(ScenarioError, match=f"^{path}: {words}"):
                read(path)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_a_scenario_path_that_is_a_fifo_says_so(tmp_path):
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    with pytest.raises(ScenarioError, match="a FIFO"):
        load_scenario(fifo)


def test_strict_json_reads_what_python_writes_and_records_every_line():
    data = {"a": [1, -2.5, {"b": None, "c": "x\ny"}], "d": True, "e": 12345678901234}
    text = json.dumps(data, indent=1)
    marks: dict = {}
    assert parse_json(text, "f.json", marks) == data
    lines = text.split("\n")
    for path in [("a",), ("a", 1), ("a", 2, "c"), ("d",)]:
        line = marks[path][1]
        assert json.dumps(path[-1]) in lines[line - 1] or "-2.5" in lines[line - 1], path


@pytest.mark.parametrize(
    "text, where, words",
    [
        ('{"a":\n [1, NaN]}', "f.json:2: a[1]", "NaN is not a JSON number"),
        ('{"a": Infinity}', "f.json:1: a", "Infinity is not a JSON number"),
        ('{"a":\n\n 1e999}', "f.json:3: a", "1e999 is too large"),
        ('{"a": ' + "7" * 400 + "}", "f.json:1: a", "an integer of 400 digits"),
        ('{"a": 1,\n "a": 2}', "f.json:2: a", "key given twice"),
        ('{"a": 1} {}', "f.json:1", "more after the end"),
        ('{"a": [1, 2}', "f.json:1", "expected ',' or ']'"),
        ("[" * (MAX_DEPTH + 1), "f.json:1: " + "[0]" * MAX_DEPTH, "nested more than"),
        ("", "f.json:1", "the document ends"),
        ("{'a': 1}", "f.json:1", "expected a key in double quotes"),
    ],
)
def test_json_that_is_not_strict_is_refused_at_its_line_and_key(text, where, words):
    with pytest.raises(ScenarioError) as caught:
        parse_json(text, "f.json", {})
    assert str(caught.value).startswith(where), str(caught.value)
    assert words in str(caught.value)
