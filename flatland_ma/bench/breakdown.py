"""Where a world-step of the batched env goes, in CPU microseconds on one thread
(``flatland-ma bench --scale`` prints it for its rows of 16 worlds and more).

A row builds ``worlds`` worlds of a scenario in one ``BatchedParallelEnv`` (the ray kernel
on this thread), steps them with random actions drawn before the clock starts, then times
the parts of a step on the state the run left:

- ``step``: a step of the env over every world, stopped before any episode ends, so that
  no reset falls in it;
- ``physics``: ``World.step`` (pymunk's step and the world's contact callbacks) of every
  world in turn, as the env runs them, each world's memory gone cold since its last turn;
- ``rays``: the ray kernel over every world in one call;
- ``rest``: ``step`` less ``physics`` and ``rays``: turning actions into forces, the
  rules, the counters, reading poses, writing the observations;
- ``reset``: one world's reset (building its world again, with the collections that the
  garbage it leaves costs) over the scenario's step limit: its share of every world-step
  when episodes run to the limit (more when they end early);
- ``bare``: ``space.step`` alone on eight worlds, each ten steps in a row (warm caches),
  as the rows' "bare physics" (``bench.BarePhysics``).

CPU time of this thread (``time.thread_time``), so that other processes taking the core do
not count against the code. The work is bounded by steps, never by the clock.
"""

from __future__ import annotations

import gc
import time
from dataclasses import asdict, dataclass

import numpy as np

from flatland_ma.bench.throughput import BarePhysics

STEPS = 60
"""Env steps timed per row (fewer when the step limit comes first): the same for every
number of worlds, so that every row's worlds are as far into their episodes."""
REPEATS = 5
"""Calls of the ray kernel and rounds of physics timed per row."""
RESETS = 64
"""Resets timed per row, at least: every world is reset once, in turn, and again from the
first until there were this many. A full collection of the garbage the resets leave
comes about once every worlds / 4 resets and costs in proportion to the worlds, so
resetting every world counts its share."""
BARE_CHUNKS = 100
"""Chunks of ``BarePhysics`` (ten steps of each of its eight worlds) per row."""


@dataclass
class Breakdown:
    """One row, microseconds of CPU per world-step (``reset``: per reset)."""

    scenario: str
    worlds: int
    agents: int
    steps: int
    """Env steps timed (each over every world)."""
    step: float
    physics: float
    rays: float
    reset: float
    step_limit: int
    bare: float

    @property
    def rest(self) -> float:
        return self.step - self.physics - self.rays

    @property
    def reset_share(self) -> float:
        """A reset's cost spread over the world-steps of an episode run to the limit."""
        return self.reset / self.step_limit

    @property
    def total(self) -> float:
        """A world-step with its share of a reset."""
        return self.step + self.reset_share

    def as_dict(self) -> dict:
        return {
            **asdict(self),
            "rest": self.rest,
            "reset_share": self.reset_share,
            "total": self.total,
        }


def measure(
    scenario: str, worlds: int, steps: int = STEPS, seed: int = 0, **overrides
) -> Breakdown:
    """The row of ``worlds`` worlds of ``scenario`` (``overrides`` as for the env), over
    ``steps`` env steps (fewer if the step limit comes first)."""
    from flatland_ma.envs.vector import BatchedParallelEnv

    env = BatchedParallelEnv(scenario, num_worlds=worlds, copy=False, parallel=False, **overrides)
    try:
        limit = env.worlds[0].step_limit
        if limit is None or limit < 3:
            raise ValueError(f"{scenario}: the breakdown needs a step limit of at least 3")
        env.reset(seed=seed)
        env.action_space.seed(seed)
        # The warm-up step and the timed ones all fall before the limit ends an episode.
        steps = max(1, min(steps, limit - 2))
        actions = [env.action_space.sample() for _ in range(min(steps, 16))]
        env.step(actions[0])
        start = time.thread_time()
        for k in range(steps):
            env.step(actions[k % len(actions)])
        step = (time.thread_time() - start) / (steps * worlds)
        if any(w.num_steps != steps + 1 for w in env.worlds):
            raise AssertionError("a world was reset during the timed steps")
        rays = _per_world(
            lambda: env.core.kernel.observe(np.arange(worlds, dtype=np.int64)), worlds
        )
        own = [w.running.world for w in env.worlds]
        physics = _per_world(lambda: [world.step() for world in own], worlds)
        reset = _resets(env, max(worlds, RESETS))
        agents = env.agents_per_world
    finally:
        env.close()
    bare = BarePhysics.of(scenario, **overrides)
    bare.run_chunks(BARE_CHUNKS)
    return Breakdown(
        scenario,
        worlds,
        agents,
        steps,
        step * 1e6,
        physics * 1e6,
        rays * 1e6,
        reset * 1e6,
        limit,
        1e6 / bare.rate,
    )


def _per_world(work, worlds: int) -> float:
    """CPU seconds of ``work`` (something done once over every world) per world, over
    ``REPEATS`` calls after one untimed call; without the collector, whose time belongs to
    whatever left the garbage."""
    work()
    enabled = gc.isenabled()
    gc.disable()
    try:
        start = time.thread_time()
        for _ in range(REPEATS):
            work()
        return (time.thread_time() - start) / (REPEATS * worlds)
    finally:
        if enabled:
            gc.enable()


def _resets(env, n: int) -> float:
    """CPU seconds per reset over ``n`` resets of the env's worlds in turn, each as the
    env resets a world whose episode ended (the collector running as it would)."""
    worlds = env.worlds
    start = time.thread_time()
    for k in range(n):
        env.core.restart(k % len(worlds))
    return (time.thread_time() - start) / n


HEADER = (
    f"{'where a world-step goes (us of CPU)':42} {'step':>7} {'physics':>8} {'rays':>7} "
    f"{'rest':>7} {'reset':>12} {'total':>7} {'bare':>6}"
)


def format_rows(rows: list[Breakdown]) -> str:
    lines = [HEADER, "-" * len(HEADER)]
    for b in rows:
        label = f"{b.scenario} x {b.worlds} ({b.agents} agents)"
        reset = f"{b.reset / 1000:.1f}ms/{b.step_limit}"
        lines.append(
            f"{label:42} {b.step:7.1f} {b.physics:8.1f} {b.rays:7.1f} {b.rest:7.1f} "
            f"{reset:>12} {b.total:7.1f} {b.bare:6.1f}"
        )
    lines.append(
        "step: an env step over every world, no reset in it; physics: World.step of every "
        "world in turn; rays: the kernel over every world; rest: step - physics - rays; "
        "reset: one world's reset over the step limit (its share is in total); bare: "
        "space.step alone, warm (the rows' bare physics). One thread, CPU time."
    )
    return "\n".join(lines)
