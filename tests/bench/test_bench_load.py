"""The benchmark's note of what other processes did to the machine during a row, from a
made-up /proc: the machine's busy time less the benchmark's own process tree's."""

from __future__ import annotations

import os

import pytest

from flatland_ma.bench import load as bench_load
from flatland_ma.bench.load import BUSY_CORES, Load, LoadMeter


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


def test_the_bare_physics_runs_after_every_slice_for_its_share_of_it(monkeypatch):
    from flatland_ma.bench import throughput as bench

    now = [0.0]  # a made-up clock that only a step moves, by 10 ms
    monkeypatch.setattr(bench.time, "perf_counter", lambda: now[0])
    events: list = []

    def step(k: int) -> None:
        now[0] += 0.01
        events.append(("step", k))

    class Bare:
        def run(self, seconds: float) -> None:
            events.append(("bare", seconds))

    rate = bench.interleaved(step, 1.2, Bare())  # type: ignore[arg-type]
    bares = [i for i, (kind, _) in enumerate(events) if kind == "bare"]
    steps = [k for kind, k in events if kind == "step"]
    assert len(bares) == bench.SLICES and bares[-1] == len(events) - 1
    assert steps == list(range(len(steps)))  # k counts the calls
    for i, b in enumerate(bares):  # each after its slice, for its share of the slice's time
        first = bares[i - 1] + 1 if i else 0
        assert b > first and events[b][1] == pytest.approx(bench.BARE_SHARE * 0.01 * (b - first))
    assert len(steps) == pytest.approx(120, abs=bench.SLICES)  # 1.2 s of 10 ms steps
    assert rate == pytest.approx(100.0)  # the steps' own time only


def test_bare_physics_counts_whole_chunks_on_the_worlds_own_space():
    import flatland_ma
    from flatland_ma.bench.throughput import BarePhysics

    env = flatland_ma.parallel_env("fruits_poisons")
    bare = BarePhysics([env])
    body = env.running.bodies[0].body
    before = body.position
    bare.run(0.0)  # one chunk at least
    bare.run(0.01)
    assert bare.steps >= 2 * BarePhysics.CHUNK and bare.steps % BarePhysics.CHUNK == 0
    assert bare.rate == bare.steps / bare.seconds > 0
    assert body.position != before or body.velocity.length == 0  # its space was stepped


def test_a_count_of_calls_is_cut_into_slices_with_the_bare_physics_between():
    from flatland_ma.bench import throughput as bench

    events: list = []

    class Bare:
        def run(self, seconds: float) -> None:
            events.append("bare")

    bench.interleaved(lambda k: events.append(k), bare=Bare(), calls=20)  # type: ignore[arg-type]
    assert [e for e in events if e != "bare"] == list(range(20))  # every call, once, in order
    assert events.count("bare") == bench.SLICES and events[-1] == "bare"
    slices = "".join("|" if e == "bare" else "." for e in events).split("|")[:-1]
    assert [len(s) for s in slices] == [
        20 * (k + 1) // bench.SLICES - 20 * k // bench.SLICES for k in range(bench.SLICES)
    ]
