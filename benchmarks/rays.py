"""Rays per second per core of the ray kernel, before and after issue 29, in one process.

The "before" is the frozen copy of the old kernel (tests/kernel_reference.py), the "after"
the shipped one (flatland_ma.sensors.kernel); both are compiled for the same arguments and
called in alternating blocks on the same worlds, the worlds stepped between blocks (not
timed), so that both share the machine's load; the ratio of their summed times is the
speed-up. Time is this thread's CPU time, so that a busy machine, which takes the core away
now and then, does not count against the kernel (the wall-clock rate is printed too). Each
block also checks that both kernels wrote the same bits.

Rows: one world per call (the single env's case, call overhead included) for each
scenario, and ``--worlds`` worlds of fruits_poisons_multi in one compiled loop (the batched
env's case, on one thread). Beside them, the physical estimate of what one core can do:
a ray that does the least work any kernel must (``MIN_CYCLES``: a few intersection tests
and one shade) at the core's clock.

    python benchmarks/rays.py [--blocks 30] [--calls 100] [--worlds 64]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numba as nb
from numba.typed import List

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import flatland_ma  # noqa: E402
from flatland_ma.sensors import kernel  # noqa: E402
from flatland_ma.sensors.sensor_suite import compiled_kernel  # noqa: E402
from tests import kernel_reference  # noqa: E402

SCENARIOS = ("fruits_poisons", "fruits_poisons_multi", "forage_rooms_multi", "maze_large")
MIN_CYCLES = 3 * 15 + 20 + 20
"""Cycles of the least work per ray: three intersection tests of about 15 cycles (a
division and a few multiplications each), one shade of about 20 (colour, intensity and a
store) and about 20 to turn the ray and find where its walk starts; any kernel pays these
whatever it culls, so one core casts at most clock / MIN_CYCLES rays a second."""


@nb.njit(cache=True)
def _new_worlds(worlds):
    for a in worlds:
        kernel.observe(a[0], a[1], a[2], a[3], a[4], a[5], a[6])


@nb.njit(cache=True)
def _old_worlds(worlds):
    for a in worlds:
        kernel_reference.observe(a[0], a[1], a[2], a[3], a[4], a[5], a[6])


def clock_mhz() -> float:
    """The core's clock from /proc/cpuinfo (the first core's), 0 if unknown."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("cpu MHz"):
                return float(line.split(":")[1])
    except OSError:
        pass
    return 0.0


def _world(name: str, seed: int):
    env = flatland_ma.parallel_env(name)
    env.reset(seed=seed)
    for a in env.possible_agents:
        env.action_space(a).seed(seed)
    _advance(env, 20)
    return env


def _advance(env, steps: int) -> None:
    for _ in range(steps):
        if not env.agents:
            env.reset()
        env.step({a: env.action_space(a).sample() for a in env.agents})


def _compare(envs, calls, blocks, make_calls) -> dict:
    """Interleaved blocks of ``calls`` calls of each version on ``envs`` (stepped between
    blocks); ``make_calls()`` gives both versions' calls on the worlds as they are now.
    CPU and wall seconds of each."""
    cpu, wall = {"old": 0.0, "new": 0.0}, {"old": 0.0, "new": 0.0}
    for b in range(blocks):
        for env in envs:
            _advance(env, 3)
        call_new, call_old = make_calls()
        call_new(), call_old()  # compiled (first block) and warm, untimed
        versions = [("new", call_new), ("old", call_old)]
        seen = {}
        for label, call in versions if b % 2 else versions[::-1]:
            c0, w0 = time.thread_time(), time.perf_counter()
            for _ in range(calls):
                call()
            cpu[label] += time.thread_time() - c0
            wall[label] += time.perf_counter() - w0
            seen[label] = [bytes(x) for env in envs for x in env.running.sensors.out]
        assert seen["new"] == seen["old"], "the kernels disagree"
    return {"cpu": cpu, "wall": wall}


def _row(label: str, rays: int, times: dict) -> str:
    cpu, wall = times["cpu"], times["wall"]
    rate = {k: rays / cpu[k] / 1e6 for k in cpu}
    return (
        f"{label:40} {rate['old']:8.2f} {rate['new']:8.2f} {cpu['old'] / cpu['new']:7.2f}x"
        f" {rays / wall['old'] / 1e6:8.2f} {rays / wall['new'] / 1e6:8.2f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--blocks", type=int, default=30)
    parser.add_argument("--calls", type=int, default=100)
    parser.add_argument("--worlds", type=int, default=64)
    opts = parser.parse_args()
    mhz = clock_mhz()
    print(f"clock {mhz:.0f} MHz, load {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    if mhz:
        print(f"physical estimate: {mhz / MIN_CYCLES:.1f} M rays/s/core ({MIN_CYCLES} cycles)")
    print(f"{'M rays/s per core':40} {'before':>8} {'after':>8} {'ratio':>8} (wall: before, after)")
    for name in SCENARIOS:
        env = _world(name, seed=0)
        args = env.running.sensors.kernel_args
        new = compiled_kernel(args, kernel.observe)
        old = compiled_kernel(args, kernel_reference.observe)

        def one_world(env=env, new=new, old=old):
            args = env.running.sensors.kernel_args
            return (lambda: new(*args)), (lambda: old(*args))

        times = _compare([env], opts.calls, opts.blocks, one_world)
        rays = opts.calls * opts.blocks * len(env.running.sensors.distance)
        print(_row(f"{name}, one world a call", rays, times), flush=True)
    envs = [_world("fruits_poisons_multi", seed=s) for s in range(opts.worlds)]

    def all_worlds():
        worlds = List([env.running.sensors.kernel_args for env in envs])
        return (lambda: _new_worlds(worlds)), (lambda: _old_worlds(worlds))

    calls = max(1, opts.calls // opts.worlds)
    times = _compare(envs, calls, opts.blocks, all_worlds)
    rays = calls * opts.blocks * sum(len(env.running.sensors.distance) for env in envs)
    print(_row(f"fruits_poisons_multi x{opts.worlds}, one call", rays, times))


if __name__ == "__main__":
    main()
