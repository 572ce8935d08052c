"""The benchmark's note of what other processes did to the machine during a row, from a
made-up /proc: the machine's busy time less the benchmark's own process tree's."""

from __future__ import annotations

import os

from flatland_ma import bench_load
from flatland_ma.bench_load import BUSY_CORES, Load, LoadMeter


def write_proc(root, busy_ticks: int, processes: dict[int, tuple[int, int]]) -> None:
    """/proc/stat with ``busy_ticks`` of user time (and a fixed idle), and one
    /proc/PID/stat per process: pid -> (parent, ticks of user time)."""
    root.mkdir(exist_ok=True)
    (root / "stat").write_text(f"cpu  {busy_ticks} 0 0 100000 0 0 0 0 0 0\ncpu0 0 0 0 0\n")
    for pid, (parent, ticks) in processes.items():
        folder = root / str(pid)
        folder.mkdir(exist_ok=True)
        fields = ["S", str(parent)] + ["0"] * 9 + [str(ticks), "0", "0", "0"] + ["0"] * 30
        (folder / "stat").write_text(f"{pid} (a (strange) name) " + " ".join(fields) + "\n")


def test_other_processes_count_and_the_benchmarks_own_tree_does_not(tmp_path, monkeypatch):
    tick = os.sysconf("SC_CLK_TCK")
    me = os.getpid()
    proc = tmp_path / "proc"
    monkeypatch.setattr(bench_load, "PROC", proc)
    clock = iter([0.0, 10.0])
    monkeypatch.setattr(bench_load.time, "perf_counter", lambda: next(clock))
    # Before: the machine has been busy 1000 ticks; we, a shard of ours and a stranger.
    tree = {me: (1, 100), 9001: (me, 50), 9002: (1, 0)}
    write_proc(proc, 1000, tree)
    meter = LoadMeter(cores=2)
    meter.start()
    # Ten seconds on: we used 4 s, our shard 6 s (together 10 core-seconds: one core),
    # and the stranger 5 s; the machine was busy for all 15.
    tree = {me: (1, 100 + 4 * tick), 9001: (me, 50 + 6 * tick), 9002: (1, 5 * tick)}
    write_proc(proc, 1000 + 15 * tick, tree)
    load = meter.stop()
    assert abs(load.other_cores - 0.5) < 1e-9  # type: ignore[operator]
    assert load.busy and "BUSY" in load.note()


def test_a_quiet_machine_is_not_flagged_and_unknown_is_said():
    assert not Load(BUSY_CORES / 2, 0.1, 2).busy
    assert "BUSY" not in Load(0.0, 0.1, 2).note()
    unknown = Load(None, 1.0, 2)
    assert not unknown.busy and "others ?" in unknown.note()


def test_without_proc_only_the_load_average_is_known(tmp_path, monkeypatch):
    monkeypatch.setattr(bench_load, "PROC", tmp_path / "missing")
    meter = LoadMeter(cores=2)
    meter.start()
    load = meter.stop()
    assert load.other_cores is None and load.load_average >= 0
