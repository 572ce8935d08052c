"""Throughput at scale: the batched env over 1 to 1024 worlds, in one process and over
every core, each beside the bare physics of the same worlds; and PPO end to end.

``flatland-ma bench --scale`` prints the table. A row steps the worlds with random actions
drawn before the clock starts, for about ``seconds`` after a warm-up step (worlds reset
themselves as their episodes end). The bare rate is ``space.step`` alone on a world of
the row's scenario (x its substeps), times the row's processes: what the physics of those
worlds would cost if nothing else ran. It is timed in slices between slices of the row's
own timing (``bench.interleaved``), so that both rates come from the same stretch of the
run.

In its seconds a row of 16 worlds goes through every world's reset several times; rows of
256 worlds and more reach no episode's end, so they leave the resets out. Where a
world-step goes (``bench_breakdown``, one thread) compares the sizes without resets and
gives a reset's share apart.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flatland_ma.bench.breakdown import Breakdown, format_rows, measure
from flatland_ma.bench.load import Load, LoadMeter
from flatland_ma.bench.targets import RayRate, bench_busy_core, bench_make_vec, bench_rays
from flatland_ma.bench.throughput import BarePhysics, BenchResult, interleaved

WORLDS = (1, 16, 256, 1024)
SECONDS = 3.0
"""How long each row is timed, after its warm-up step."""
SCENARIOS = ("fruits_poisons", "fruits_poisons_multi")
"""One and four agents per world, a 64-ray RGB-D camera each."""


def cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def bench_worlds(
    scenario: str, worlds: int, processes: int = 1, seconds: float = SECONDS, **overrides
) -> BenchResult:
    """World steps per second of ``worlds`` worlds in one batched env (``processes`` 1)
    or sharded over ``processes`` processes; ``overrides`` as for the envs."""
    from flatland_ma.envs.shards import ShardedParallelEnv
    from flatland_ma.envs.vector import BatchedParallelEnv

    bare = BarePhysics.of(scenario, **overrides)
    if processes == 1:
        env = BatchedParallelEnv(scenario, num_worlds=worlds, copy=False, **overrides)
    else:
        env = ShardedParallelEnv(scenario, worlds, shards=processes, copy=False, **overrides)
    try:
        rate, load = timed_steps(env, worlds, seconds, bare)
        processes, agents = getattr(env, "num_shards", 1), env.agents_per_world
        threads = f"{processes} x 1" if processes > 1 else _kernel_threads(env)
    finally:
        env.close()
    where = "1 process" if processes == 1 else f"{processes} processes"
    label = f"batched {scenario} x {worlds}, {where}"
    return BenchResult(label, agents, rate, bare.rate * processes, threads, load)


def timed_steps(
    env, worlds: int, seconds: float, bare: BarePhysics | None = None
) -> tuple[float, Load]:
    """World steps per second of a batched (or sharded) env of ``worlds`` worlds stepped
    with random actions for ``seconds`` (at least 3 steps, after a reset and one untimed
    step; ``bare`` timed between its slices), and what other processes did meanwhile."""
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(16)]
    env.step(actions[0])  # warm-up
    meter = LoadMeter(cores())
    meter.start()
    rate = interleaved(lambda k: env.step(actions[k % len(actions)]), seconds, bare) * worlds
    return rate, meter.stop()


def _kernel_threads(env) -> str:
    """``1 x N``: one process whose ray kernel may use N threads, and whether it chose
    them (``threads.Chooser``) at the row's end."""
    import numba

    from flatland_ma.sensors.threads import Chooser

    function = env.core.kernel.function
    using = "all" if isinstance(function, Chooser) and function.parallel else "1"
    return f"1 x {numba.get_num_threads()} (using {using})"


@dataclass
class TrainingRate:
    label: str
    agent_steps_per_s: float | None
    note: str = ""


def bench_ppo(steps: int = 65_536, worlds: int = 16, root: Path | None = None) -> TrainingRate:
    """Agent-steps per second of the baselines' PPO end to end (acting, stepping and
    learning) on fruits_poisons_multi, torch on every core; measured by running
    ``python -m baselines.ppo`` from the checkout the package sits in (the baselines are
    not part of the installed package)."""
    label = f"PPO end to end, fruits_poisons_multi x {worlds}, {cores()} cores"
    root = root or Path(__file__).resolve().parents[2]
    if not (root / "baselines" / "ppo.py").exists():
        return TrainingRate(label, None, "not measured: baselines/ is in a checkout only")
    with tempfile.TemporaryDirectory() as out:
        csv = Path(out) / "seed_0.csv"
        command = [
            sys.executable, "-m", "baselines.ppo", "--scenario", "fruits_poisons_multi",
            "--num-envs", str(worlds), "--total-timesteps", str(steps),
            "--torch-threads", str(cores()), "--checkpoint-every", "0", "--no-tensorboard",
            "--csv", str(csv),
        ]  # fmt: skip
        done = subprocess.run(command, cwd=root, capture_output=True, text=True)
        if done.returncode != 0:
            return TrainingRate(label, None, f"failed: {done.stderr.strip()[-300:]}")
        summary = json.loads(csv.with_suffix(".json").read_text())
    return TrainingRate(label, summary["steps"] / summary["wall_seconds"])


def _processes(worlds: int) -> list[int]:
    """The rows of ``worlds`` worlds: one process, and as many as the cores (or worlds)."""
    return sorted({1, min(cores(), worlds)})


def check_worlds(worlds: tuple[int, ...]) -> None:
    """``ValueError`` (naming the scenario and ``--worlds``) unless every row ``run`` would
    measure fits the work budget (``budget.check_batch``: worlds x agents x sensors)."""
    from flatland_ma.scenario.budget import check_batch
    from flatland_ma.scenario.loader import load_scenario

    for scenario in SCENARIOS:
        spec = load_scenario(scenario)
        for n in worlds:
            for processes in _processes(n):
                try:
                    check_batch(spec, n, "--worlds", processes if processes > 1 else 0)
                except ValueError as err:
                    raise ValueError(f"{scenario}: {err}") from None


TARGET_WORLDS = 256
"""Worlds of the make_vec row and of the ray kernel's row (the issue's targets)."""
BUSY_WORLDS = 16
"""Worlds of the rows with and without a busy process holding a core."""


@dataclass
class ScaleRun:
    """What ``run`` measured: the rows of worlds and the targets' rows, PPO end to end,
    the ray kernel's rate, and where a world-step goes (``bench_breakdown``)."""

    results: list[BenchResult]
    training: list[TrainingRate]
    rays: RayRate | None = None
    breakdowns: list[Breakdown] = field(default_factory=list)


BREAKDOWN_WORLDS = 16
"""Rows of worlds from this many up get a breakdown of their world-step."""


def run(worlds: tuple[int, ...] = WORLDS, seconds: float = SECONDS, ppo: bool = True) -> ScaleRun:
    """Every row of worlds (one process, and every core), then the targets' rows
    (``bench_targets``), the ray kernel's rate, where a world-step goes (one thread, rows
    of ``BREAKDOWN_WORLDS`` worlds or more) and PPO end to end (unless not ``ppo``)."""
    check_worlds(worlds)
    results = []
    for scenario in SCENARIOS:
        for n in worlds:
            for processes in _processes(n):
                results.append(bench_worlds(scenario, n, processes, seconds))
    results += bench_make_vec(TARGET_WORLDS, seconds)
    results += bench_busy_core(BUSY_WORLDS, seconds)
    rays = bench_rays(TARGET_WORLDS, seconds)
    breakdowns = [
        measure(scenario, n) for scenario in SCENARIOS for n in worlds if n >= BREAKDOWN_WORLDS
    ]
    return ScaleRun(results, [bench_ppo()] if ppo else [], rays, breakdowns)


def format_table(scale: ScaleRun) -> str:
    results, training, rays = scale.results, scale.training, scale.rays
    header = (
        f"{'batched env':48} {'agents':>6} {'world steps/s':>14} {'agent steps/s':>14} "
        f"{'bare physics/s':>15} {'cost / bare':>12}  {'threads':18} machine"
    )
    lines = [header, "-" * len(header)]
    for r in results:
        lines.append(
            f"{r.label:48} {r.agents:>6} {r.env_steps_per_s:>14,.0f} {r.agent_steps_per_s:>14,.0f} "
            f"{r.bare_steps_per_s:>15,.0f} {_cost(r):>12}  {r.threads:18} "
            f"{r.load.note() if r.load else ''}"
        )
    lines.append(
        "bare physics/s: world-step equivalents of space.step alone on a world of the "
        "row's scenario, times the row's processes, timed in slices between the row's own "
        "(the same stretch of the run). cost / bare: time per world-step over the "
        "bare physics' time. threads: processes x threads each (the ray kernel uses all "
        "of its threads or one, whichever is faster under the load). machine: cores that "
        "other processes kept busy during the row; BUSY rows were taken while other work "
        "held the cores, so they understate the code."
    )
    if rays is not None:
        lines.append(
            f"{rays.label}: {rays.rays_per_s_per_core / 1e6:,.1f} million rays/s per core "
            f"(CPU time; {rays.wall_rays_per_s / 1e6:,.1f} million by the wall clock)"
        )
    for t in training:
        rate = f"{t.agent_steps_per_s:,.0f} agent-steps/s" if t.agent_steps_per_s else t.note
        lines.append(f"{t.label}: {rate}")
    if scale.breakdowns:
        lines += ["", format_rows(scale.breakdowns)]
    return "\n".join(lines)


def _cost(r: BenchResult) -> str:
    """Time per world-step over bare physics' (blank for rows without bare physics)."""
    return f"{r.bare_steps_per_s / r.env_steps_per_s:.1f}x" if r.bare_steps_per_s else ""


def as_json(scale: ScaleRun) -> dict:
    results, training, rays = scale.results, scale.training, scale.rays
    return {
        "batched": [
            {
                "environment": r.label,
                "agents": r.agents,
                "world_steps_per_s": r.env_steps_per_s,
                "agent_steps_per_s": r.agent_steps_per_s,
                "bare_space_step_per_s": r.bare_steps_per_s or None,
                **r.machine(),
            }
            for r in results
        ],
        "training": [
            {"run": t.label, "agent_steps_per_s": t.agent_steps_per_s, "note": t.note}
            for t in training
        ],
        "rays": None
        if rays is None
        else {
            "run": rays.label,
            "rays_per_s_per_core": rays.rays_per_s_per_core,
            "wall_rays_per_s": rays.wall_rays_per_s,
        },
        "breakdown": [b.as_dict() for b in scale.breakdowns],
        "cores": cores(),
        "numpy": np.__version__,
    }
