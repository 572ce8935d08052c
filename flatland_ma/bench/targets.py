"""The scale targets the rows of worlds do not give by themselves (``bench --scale``):

- ``gymnasium.make_vec`` at 256 worlds beside one ``gymnasium.make`` env of the same id;
- the batched env with one core held by a busy process (numba's threads, as chosen) beside
  its rate on one thread, measured in turn in the same run;
- the ray kernel alone over many worlds on one thread: rays per second per core (CPU time
  of this thread, so that other processes taking the core do not count against it).

Each row steps with random actions drawn before the clock starts, for about ``seconds``.
"""

from __future__ import annotations

import subprocess
import sys
import time
from dataclasses import dataclass

import numpy as np

from flatland_ma.bench.load import LoadMeter
from flatland_ma.bench.throughput import BarePhysics, BenchResult, interleaved
from flatland_ma.sensors.threads import usable_cpus

SCENARIO = "fruits_poisons"
"""One agent, a 64-ray RGB-D camera: the Gymnasium id's scenario."""
MULTI = "fruits_poisons_multi"


def _rate(step, actions: list, seconds: float, bare: BarePhysics | None = None) -> float:
    """Calls of ``step`` per second, cycling through ``actions``, after one warm-up call
    (``bare`` timed between slices of it)."""
    step(actions[0])
    return interleaved(lambda k: step(actions[k % len(actions)]), seconds, bare)


def bench_make_vec(worlds: int, seconds: float) -> list[BenchResult]:
    """``make_vec(id, num_envs=worlds)`` and one ``make(id)`` env, each beside bare physics."""
    import gymnasium

    from flatland_ma.envs.registration import gym_id

    name = gym_id(SCENARIO)
    rows = []
    for label, n in ((f"make_vec {name} x {worlds}", worlds), (f"make {name}", 0)):
        env = gymnasium.make_vec(name, num_envs=n) if n else gymnasium.make(name)
        bare = BarePhysics.of(SCENARIO)
        meter = LoadMeter(usable_cpus())
        try:
            env.reset(seed=0)
            env.action_space.seed(0)
            actions = [env.action_space.sample() for _ in range(16)]
            meter.start()
            step = env.step if n else _restarting(env)
            rate = _rate(step, actions, seconds, bare) * max(1, n)
            load = meter.stop()
        finally:
            env.close()
        threads = "1 x 1" if not n else "1 x all"
        rows.append(BenchResult(label, 1, rate, bare.rate, threads, load))
    return rows


def _restarting(env):
    """``env.step``, resetting the (single) env when its episode ends."""

    def step(action) -> None:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()

    return step


def bench_busy_core(worlds: int, seconds: float) -> list[BenchResult]:
    """The batched ``MULTI`` x ``worlds`` on one thread, then with its threads as chosen
    while a busy process (a Python loop, started here and ended here) holds a core."""
    from flatland_ma.envs.vector import BatchedParallelEnv

    rows = []
    for parallel in (False, True):
        env = BatchedParallelEnv(MULTI, num_worlds=worlds, copy=False, parallel=parallel)
        busy = None
        try:
            env.reset(seed=0)
            env.action_space.seed(0)
            actions = [env.action_space.sample() for _ in range(16)]
            if parallel:
                busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            meter = LoadMeter(usable_cpus())
            meter.start()
            rate = _rate(env.step, actions, seconds) * worlds
            load = meter.stop()
        finally:
            if busy is not None:
                busy.kill()
                busy.wait()
            env.close()
        label = f"batched {MULTI} x {worlds}, " + (
            "threads, a busy process holding one core" if parallel else "one thread"
        )
        threads = f"1 x {usable_cpus()}" if parallel else "1 x 1"
        rows.append(BenchResult(label, env.agents_per_world, rate, 0.0, threads, load))
    return rows


@dataclass
class RayRate:
    label: str
    rays_per_s_per_core: float
    wall_rays_per_s: float


def bench_rays(worlds: int, seconds: float) -> RayRate:
    """The ray kernel alone on ``worlds`` worlds of ``MULTI`` in one call on one thread;
    the worlds are stepped between calls (not timed) so that the rays see play."""
    from flatland_ma.envs.vector import BatchedParallelEnv

    env = BatchedParallelEnv(MULTI, num_worlds=worlds, copy=False, parallel=False)
    try:
        env.reset(seed=0)
        env.action_space.seed(0)
        which = np.arange(worlds, dtype=np.int64)
        rays = sum(len(w.running.sensors.image) for w in env.worlds)
        cpu = wall = 0.0
        calls = 0
        while calls < 3 or wall < seconds:
            env.step(env.action_space.sample())
            c0, w0 = time.thread_time(), time.perf_counter()
            env.core.kernel.observe(which)
            cpu += time.thread_time() - c0
            wall += time.perf_counter() - w0
            calls += 1
    finally:
        env.close()
    label = f"ray kernel, {MULTI} x {worlds} in one call, one thread"
    return RayRate(label, calls * rays / max(cpu, 1e-9), calls * rays / max(wall, 1e-9))
