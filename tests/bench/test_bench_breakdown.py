"""Where a world-step goes (``bench_breakdown``): each part is timed on the env's own
worlds, the timed steps stop before any episode ends, the resets go round every world, and
the figures reach the table, the JSON and the performance page."""

from __future__ import annotations

import json
import time
from collections import Counter

import pytest

from benchmarks.performance_table import breakdown_table, table
from flatland_ma.bench import breakdown as bench_breakdown
from flatland_ma.bench.breakdown import Breakdown, format_rows, measure
from flatland_ma.bench.scale import ScaleRun, as_json, format_table


def test_a_row_times_its_parts_on_the_envs_worlds(monkeypatch):
    # Count what each part did: the kernel's calls over every world, World.step's calls,
    # and the resets.
    from flatland_ma.envs.worlds import Worlds
    from flatland_ma.sensors.sensor_suite import WorldsKernel
    from flatland_ma.world.world import World

    kernel_calls, world_steps, restarts = [], Counter(), []
    observe, step, restart = WorldsKernel.observe, World.step, Worlds.restart

    def counted_observe(self, which):
        kernel_calls.append(len(which))
        return observe(self, which)

    def counted_step(self):
        world_steps[id(self)] += 1
        return step(self)

    def counted_restart(self, w, seed=None):
        restarts.append(w)
        return restart(self, w, seed)

    monkeypatch.setattr(WorldsKernel, "observe", counted_observe)
    monkeypatch.setattr(World, "step", counted_step)
    monkeypatch.setattr(Worlds, "restart", counted_restart)
    monkeypatch.setattr(bench_breakdown, "RESETS", 5)
    row = measure("fruits_poisons_multi", 2, steps=4, max_cycles=50)

    assert (row.worlds, row.agents, row.steps, row.step_limit) == (2, 4, 4, 50)
    # The warm-up and the 4 timed steps, then the kernel's untimed call and REPEATS more,
    # each over both worlds.
    assert kernel_calls == [2] * (1 + 4 + 1 + bench_breakdown.REPEATS)
    # World.step: each of the batch's 2 worlds 5 env steps, then 1 + REPEATS rounds; the
    # bare physics' 8 worlds their 20 steps of play before their spaces are timed alone.
    assert sorted(world_steps.values()) == [5 + 1 + bench_breakdown.REPEATS] * 2 + [20] * 8
    # reset(seed) restarts both worlds, then 5 timed resets go round them.
    assert restarts == [0, 1] + [0, 1, 0, 1, 0]
    for part in (row.step, row.physics, row.rays, row.reset, row.bare):
        assert part > 0
    assert row.rest == pytest.approx(row.step - row.physics - row.rays)
    assert row.total == pytest.approx(row.step + row.reset / 50)


def test_the_timed_steps_stop_before_the_step_limit_ends_an_episode():
    # Asked for 60 steps where episodes last 6: the warm-up and 4 timed steps, no reset
    # (measure raises if any world was reset while timed).
    row = measure("fruits_poisons", 1, steps=60, max_cycles=6)
    assert row.steps == 4
    with pytest.raises(ValueError, match="step limit"):
        measure("fruits_poisons", 1, max_cycles=2)


def test_per_world_time_leaves_out_the_collector_and_divides_by_the_worlds(monkeypatch):
    # A made-up thread clock that moves 1 s per call of the work, and a collector that
    # must be off while it is timed.
    clock = [0.0]
    monkeypatch.setattr(bench_breakdown.time, "thread_time", lambda: clock[0])
    seen = []

    def work():
        seen.append(bench_breakdown.gc.isenabled())
        clock[0] += 1.0

    assert bench_breakdown._per_world(work, 4) == pytest.approx(1.0 / 4)
    assert seen == [True] + [False] * bench_breakdown.REPEATS
    assert bench_breakdown.gc.isenabled()


def made_up(**parts) -> Breakdown:
    values = dict(
        scenario="fruits_poisons_multi", worlds=256, agents=4, steps=60, step=100.0,
        physics=20.0, rays=30.0, reset=5000.0, step_limit=500, bare=8.0,
    )  # fmt: skip
    return Breakdown(**{**values, **parts})


def test_the_figures_reach_the_table_the_json_and_the_page():
    row = made_up()
    assert (row.rest, row.reset_share, row.total) == (50.0, 10.0, 110.0)
    text = format_rows([row])
    line = next(x for x in text.splitlines() if x.startswith("fruits_poisons_multi x 256"))
    assert line.split() == [
        "fruits_poisons_multi", "x", "256", "(4", "agents)",
        "100.0", "20.0", "30.0", "50.0", "5.0ms/500", "110.0", "8.0",
    ]  # fmt: skip
    scale = ScaleRun([], [], None, [row])
    assert "where a world-step goes" in format_table(scale)
    data = json.loads(json.dumps(as_json(scale)))
    (saved,) = data["breakdown"]
    assert saved["rest"] == 50.0 and saved["total"] == 110.0 and saved["physics"] == 20.0
    page = table(data)
    assert breakdown_table(data["breakdown"]) in page
    assert "| fruits_poisons_multi x 256 (4 agents) | 100.0 | 20.0 | 30.0 | 50.0 " in page
    assert "5.0 ms / 500 steps (10.0)" in page
    # A run without a breakdown (an older JSON) gives the page as before.
    assert "where a world-step goes" not in table({**data, "breakdown": []})


def test_the_bare_chunks_count_the_worlds_steps(monkeypatch):
    from flatland_ma.bench.throughput import BarePhysics

    bare = BarePhysics.of("fruits_poisons", worlds=2)
    stepped = []
    for space, _, _ in bare._worlds:
        monkeypatch.setattr(space, "step", lambda dt, s=space: stepped.append(s))
    clock = iter([1.0, 3.0])
    monkeypatch.setattr(time, "thread_time", lambda: next(clock))
    bare.run_chunks(3)
    substeps = bare._worlds[0][2] // BarePhysics.CHUNK
    assert len(stepped) == 2 * 3 * BarePhysics.CHUNK * substeps
    assert bare.steps == 2 * 3 * BarePhysics.CHUNK and bare.seconds == 2.0
