"""Throughput of the environments, each beside the bare ``space.step`` rate of its world.

The figure of merit is the ratio: how much of the env step is physics. Every rate is
measured on one core (the ray kernel is single-threaded) with random actions drawn
before the clock starts.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import gymnasium

from flatland_ma.bench.load import Load, LoadMeter
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.envs.registration import gym_id


@dataclass
class BenchResult:
    label: str
    agents: int
    env_steps_per_s: float
    bare_steps_per_s: float
    """Environment-step equivalents per second of ``space.step`` alone (x substeps)."""
    threads: str = ""
    """How the row's work was spread: processes x threads, and the ray kernel's choice."""
    load: Load | None = None
    """What other processes did to the machine while the row ran."""

    @property
    def agent_steps_per_s(self) -> float:
        return self.env_steps_per_s * self.agents

    @property
    def physics_share(self) -> float:
        return self.env_steps_per_s / self.bare_steps_per_s

    def machine(self) -> dict:
        """The row's threads and what other processes did meanwhile, for JSON."""
        load = self.load
        return {
            "threads": self.threads,
            "other_cores": load.other_cores if load else None,
            "load_average": load.load_average if load else None,
            "busy": load.busy if load else None,
        }


def bench_gym(scenario: str, steps: int, seed: int = 0) -> BenchResult:
    """Steps per second of ``gymnasium.make(<id>)`` (with Gymnasium's own wrappers)."""
    env = gymnasium.make(gym_id(scenario))
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]
    bare = BarePhysics.of(scenario)

    def step(k: int) -> None:
        _, _, terminated, truncated, _ = env.step(actions[k])
        if terminated or truncated:
            env.reset()

    rate = interleaved(step, bare=bare, calls=steps)
    env.close()
    return BenchResult(f"gym {gym_id(scenario)}", 1, rate, bare.rate)


def bench_parallel(scenario: str, steps: int, seed: int = 0) -> BenchResult:
    """Env steps per second of the PettingZoo parallel env (all agents act each step)."""
    env = FlatlandParallelEnv(scenario)
    env.reset(seed=seed)
    spaces = [env.action_space(a) for a in env.possible_agents]
    for i, space in enumerate(spaces):
        space.seed(seed + i)
    actions = [{a: s.sample() for a, s in zip(env.possible_agents, spaces)} for _ in range(steps)]
    bare = BarePhysics.of(scenario)

    def step(k: int) -> None:
        env.step(actions[k])
        if not env.agents:
            env.reset()

    rate = interleaved(step, bare=bare, calls=steps)
    env.close()
    return BenchResult(f"parallel {scenario}", len(env.possible_agents), rate, bare.rate)


BATCH_WORLDS = 16
"""Worlds in the batched env's rows of the table."""


def bench_batched(scenario: str, steps: int, seed: int = 0) -> BenchResult:
    """World steps per second of ``BatchedParallelEnv`` with ``BATCH_WORLDS`` worlds
    (about ``steps`` world steps in all; worlds reset themselves)."""
    from flatland_ma.envs.vector import BatchedParallelEnv

    batch = BatchedParallelEnv(scenario, num_worlds=BATCH_WORLDS, copy=False)
    batch.reset(seed=seed)
    batch.action_space.seed(seed)
    rounds = max(1, steps // BATCH_WORLDS)
    actions = [batch.action_space.sample() for _ in range(rounds)]
    bare = BarePhysics.of(scenario)
    rate = interleaved(lambda k: batch.step(actions[k]), bare=bare, calls=rounds) * BATCH_WORLDS
    batch.close()
    label = f"batched {scenario} x {BATCH_WORLDS} worlds"
    return BenchResult(label, batch.agents_per_world, rate, bare.rate)


class BarePhysics:
    """``space.step`` alone on the worlds of ``envs``, in turn (each after a reset and 20
    steps of seeded random actions, so that bodies move and touch as they do in play: how
    many touch changes the physics' cost by up to 2x, so one world is a poor sample),
    timed in slices: ``run(seconds)`` steps them for about that long, ``rate`` is
    env-step equivalents (x substeps) per second over every slice so far. Run between the
    slices of a row's own timing (``interleaved``), it gives a bare rate from the same
    stretch of the run, so that the machine's drift moves both rates alike."""

    CHUNK = 10
    """Env-step equivalents of each world between two reads of the clock."""

    def __init__(self, envs: list[FlatlandParallelEnv]):
        self._worlds = []
        for k, env in enumerate(envs):
            env.reset(seed=1 + k)
            for i, agent in enumerate(env.possible_agents):
                env.action_space(agent).seed(1000 * k + i)
            for _ in range(20):
                if not env.agents:  # an episode shorter than that
                    break
                env.step({a: env.action_space(a).sample() for a in env.agents})
            world = env.running.world
            self._worlds.append((world.space, world.substep_dt, world.substeps * self.CHUNK))
        self.steps, self.seconds = 0, 0.0

    @classmethod
    def of(cls, scenario, worlds: int = 8, **overrides) -> BarePhysics:
        """``worlds`` worlds of ``scenario`` (with ``overrides``), seeded 1 to ``worlds``."""
        return cls([FlatlandParallelEnv(scenario, **overrides) for _ in range(worlds)])

    def run(self, seconds: float) -> None:
        start = time.perf_counter()
        while True:
            self._chunk()
            elapsed = time.perf_counter() - start
            if elapsed >= seconds:
                break
        self.seconds += elapsed

    def run_chunks(self, chunks: int) -> None:
        """Step the worlds ``chunks`` times (``CHUNK`` steps each), timed on this thread's
        CPU clock: bounded by work, not by the clock."""
        start = time.thread_time()
        for _ in range(chunks):
            self._chunk()
        self.seconds += time.thread_time() - start

    def _chunk(self) -> None:
        """``CHUNK`` env-step equivalents of every world, counted."""
        for space, dt, substeps in self._worlds:
            for _ in range(substeps):
                space.step(dt)
        self.steps += self.CHUNK * len(self._worlds)

    @property
    def rate(self) -> float:
        return self.steps / self.seconds if self.seconds else 0.0


SLICES = 6
"""Slices a row's timing is cut into, with the bare physics run after each."""
BARE_SHARE = 0.25
"""The bare physics' time after each slice, as a share of the slice's."""


def interleaved(
    step: Callable[[int], object],
    seconds: float | None = None,
    bare: BarePhysics | None = None,
    calls: int | None = None,
) -> float:
    """Calls per second of ``step(k)`` (k counts the calls) over about ``seconds`` of its
    own time (at least 3 calls), or over exactly ``calls`` calls; the work is cut into
    ``SLICES`` slices, each followed by ``bare`` for ``BARE_SHARE`` of its time (when
    given)."""
    done, spent = 0, 0.0
    for k in range(SLICES):
        start = time.perf_counter()
        if calls is not None:
            for _ in range(calls * (k + 1) // SLICES - done):
                step(done)
                done += 1
        else:
            assert seconds is not None, "give seconds or calls"
            while done < 3 * (k + 1) // SLICES or time.perf_counter() - start < seconds / SLICES:
                step(done)
                done += 1
        elapsed = time.perf_counter() - start
        spent += elapsed
        if bare is not None:
            bare.run(BARE_SHARE * elapsed)
    return done / spent


LARGEST = "maze_large"
"""The biggest layout in the library: its rate shows what large worlds cost."""
WITH_PARTS = "tug_of_war"
"""Four agents with heads, arms and graspers: compare with fruits_poisons_multi's plain bodies."""


BENCHED = (
    (bench_gym, "fruits_poisons"),
    (bench_parallel, "fruits_poisons_multi"),
    (bench_gym, LARGEST),
    (bench_parallel, "forage_rooms_multi"),
    (bench_parallel, WITH_PARTS),
    (bench_batched, "fruits_poisons"),
    (bench_batched, "fruits_poisons_multi"),
)
"""What ``flatland-ma bench`` measures, in order."""


def run(steps: int = 20_000) -> list[BenchResult]:
    """Every row of ``BENCHED``, each with the load other processes put on the machine
    while it ran."""
    from flatland_ma.sensors.threads import fit_threads, usable_cpus

    meter, results = LoadMeter(usable_cpus()), []
    for bench, scenario in BENCHED:
        meter.start()
        result = bench(scenario, steps)
        threads = f"1 x {fit_threads()}"
        threads = threads if bench is bench_batched else "1 x 1"
        results.append(replace(result, threads=threads, load=meter.stop()))
    return results


def format_table(results: list[BenchResult]) -> str:
    header = (
        f"{'environment':44} {'agents':>6} {'env steps/s':>12} {'agent steps/s':>14} "
        f"{'bare space.step/s':>18} {'env/bare':>9}  {'threads':8} machine"
    )
    lines = [header, "-" * len(header)]
    for r in results:
        lines.append(
            f"{r.label:44} {r.agents:>6} {r.env_steps_per_s:>12,.0f} {r.agent_steps_per_s:>14,.0f} "
            f"{r.bare_steps_per_s:>18,.0f} {r.physics_share:>8.0%}  {r.threads:8} "
            f"{r.load.note() if r.load else ''}"
        )
    lines.append(
        "bare space.step/s: environment-step equivalents (substeps x space.step) per second "
        "on eight worlds of the scenario, timed in slices between the row's own. Rates "
        "include resets (a new layout each episode where the scenario asks for one). "
        "Batched rows: env steps are world steps, all worlds together. threads: processes x "
        "threads. machine: cores other processes kept busy during the row (BUSY: the row "
        "understates the code)."
    )
    lines += [f"{text}: {ratio:.2f}x slower" for text, ratio in comparisons(results)]
    return "\n".join(lines)


COMPARISONS = (
    (f"gym {gym_id('fruits_poisons')}", f"gym {gym_id(LARGEST)}", "env", "largest layout"),
    ("parallel fruits_poisons_multi", f"parallel {WITH_PARTS}", "agent", "bodies with parts"),
)
"""(reference, compared, rate, what): the costs the library keeps within 2x."""


def comparisons(results: list[BenchResult]) -> list[tuple[str, float]]:
    """For each pair in ``COMPARISONS`` that was measured: its text and how many times
    slower the compared environment is than the reference (env or agent steps/s)."""
    by_label = {r.label: r for r in results}
    out = []
    for reference, compared, rate, what in COMPARISONS:
        if reference in by_label and compared in by_label:
            a, b = by_label[reference], by_label[compared]
            ratio = getattr(a, f"{rate}_steps_per_s") / getattr(b, f"{rate}_steps_per_s")
            out.append((f"{what} ({compared} vs {reference}, {rate} steps/s)", ratio))
    return out
