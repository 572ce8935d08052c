"""docs/performance.md's table of the latest `bench --scale --json` run is what
benchmarks/performance_table.py writes from the committed JSON, and it shows every row."""

from __future__ import annotations

import json

import pytest

from benchmarks.performance_table import (
    BEGIN,
    END,
    PAGE,
    PEERS,
    PEERS_BEGIN,
    PEERS_END,
    RESULTS,
    peers_table,
    rewrite,
    table,
)


def test_the_page_holds_the_table_of_the_committed_run():
    page = PAGE.read_text()
    data = json.loads(RESULTS.read_text())
    assert rewrite(page, data) == page, "run: python -m benchmarks.performance_table"
    batched = table(data).partition("\n\n")[0]  # the rows' table, before the notes
    rows = [line for line in batched.splitlines() if line.startswith("| ")][1:]
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


def test_the_page_holds_vmas_beside_flatland_ma_from_the_committed_run():
    page = PAGE.read_text()
    peers = json.loads(PEERS.read_text())
    assert rewrite(page, json.loads(RESULTS.read_text()), peers) == page, (
        "run: python -m benchmarks.performance_table"
    )
    # Each size and core count was measured for all three: VMAS, our lidar, our camera.
    kinds = {}
    for row in peers["rows"]:
        kind = "vmas" if row["system"].startswith("vmas") else row["sensor"]
        kinds.setdefault((row["cores"], row["worlds"]), set()).add(kind)
    assert kinds and all(found == {"vmas", "lidar", "camera"} for found in kinds.values())
    section = page.partition(PEERS_BEGIN)[2].partition(PEERS_END)[0]
    assert len([line for line in section.splitlines() if line.startswith("| ")]) == len(kinds) + 1


def test_the_peers_table_gives_the_ratio_and_flags_busy_rows():
    def row(system, sensor, rate, busy=False):
        return {"system": system, "sensor": sensor, "worlds": 16, "agents": 4, "cores": 1,
                "agent_steps_per_s": rate, "load_average": 1.0, "busy": busy}  # fmt: skip

    peers = {
        "scenario": "fruits_poisons_multi",
        "rows": [
            row("vmas 1.5.2", "lidar", 1000.0),
            row("flatland_ma 1", "lidar", 5000.0),
            row("flatland_ma 1", "camera", 4000.0, busy=True),
        ],
    }
    line = [x for x in peers_table(peers).splitlines() if x.startswith("| 16 x 4")][0]
    assert "| 1,000 | 5,000 | 4,000 (BUSY) | 4.0x |" in line
    with pytest.raises(ValueError, match="peers-json"):
        rewrite(f"{BEGIN}\n{END}\n", {"batched": [], "cores": 2, "numpy": "2"}, peers)
