"""docs/performance.md's table of the latest `bench --scale --json` run is what
benchmarks/performance_table.py writes from the committed JSON, and it shows every row."""

from __future__ import annotations

import json

import pytest

from benchmarks.performance_table import BEGIN, END, PAGE, RESULTS, rewrite, table


def test_the_page_holds_the_table_of_the_committed_run():
    page = PAGE.read_text()
    data = json.loads(RESULTS.read_text())
    assert rewrite(page, data) == page, "run: python -m benchmarks.performance_table"
    rows = [line for line in table(data).splitlines() if line.startswith("| ")][1:]
    assert len(rows) == len(data["batched"])
    # Every row carries its threads and the load it was measured under.
    for row, line in zip(data["batched"], rows, strict=True):
        assert row["threads"] in line and f"{row['load_average']:.2f}" in line
        assert ("BUSY" in line) == row["busy"]


def test_a_page_without_the_marks_is_refused():
    data = {"batched": [], "cores": 2, "numpy": "2"}
    with pytest.raises(ValueError, match="scale-json"):
        rewrite("# Performance\n", data)
    assert rewrite(f"a\n{BEGIN}\nold\n{END}\nb", data).endswith(f"{END}\nb")
