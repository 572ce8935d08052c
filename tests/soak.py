"""Soak run: many agent-steps and many env creations in one process, watching memory and speed.

    python -m tests.soak                                   # 1,000,000 agent-steps, 500 creations
    python -m tests.soak --agent-steps 20000 --creations 20

Phase 1 steps one ``parallel_env`` with seeded random actions drawn from the action spaces,
resetting with a new seed whenever every agent is done, and counts agent-steps as the live
agents of each env step. Every observation is checked: a vectorised bounds test on all
agents' observations each step (it fails on NaN and infinities too), and the space's own
``contains`` every ``contains_every`` env steps and on every reset (about 20 us an agent,
as much as the whole step, so not on every one). The resident set size and the rate are
sampled every ``window`` agent-steps, the rate both per second and per CPU second of the
process (which other work on the machine does not lower). The first ``warmup`` share of
the steps is warm-up (allocator arenas, caches and free lists filling up); growth is the
change of RSS from the end of warm-up to the end of the run.

Phase 2 creates, resets, steps a few times and closes ``creations`` envs, sampling RSS
every ``creation_window`` creations; growth is the change of RSS from the end of the first
``warmup`` share of creations to the last.

Each sample follows a full collection (``gc.collect``): pymunk's bodies, shapes and space
refer to each other, so a closed env's world (and a reset's old one) is freed only by the
cyclic collector, about 900 objects and the memory of their C structures each. Left to
the collector's own thresholds, a loop of creations holds more of them at once: RSS then
climbs by about 24 MB over the first 350 creations or so and stays there (flat from 400
to 1,500 creations), a level that says when the collector runs, not what is kept. With a
collection every 10 creations, and every 50,000 agent-steps (25 episodes) in phase 1,
what RSS shows after warm-up is what the envs keep.

``run_soak`` returns the report as a dict; the command prints it and exits with 1 if an
observation was bad or either growth reached ``--max-growth`` percent.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import sys
import time

import gymnasium
import numpy as np

import flatland_ma

SCENARIO = "fruits_poisons_multi"
MAX_GROWTH = 5.0
"""Percent of RSS growth after warm-up that counts as a leak."""


def rss_source() -> str:
    if os.path.exists("/proc/self/statm"):
        return "statm"
    try:
        import psutil  # noqa: F401  (optional: only where /proc is missing)
    except ImportError:
        return "peak"
    return "psutil"


def rss_bytes(source: str) -> int:
    """The process's resident set size, or where neither /proc nor psutil is there its
    peak (ru_maxrss), which still shows a leak as growth."""
    if source == "statm":
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    if source == "psutil":
        import psutil

        return psutil.Process().memory_info().rss
    import resource

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak if sys.platform == "darwin" else peak * 1024


class ObservationCheck:
    """Checks the observations of one env against its observation spaces: fast bounds
    test on every call, the space's ``contains`` when asked; the bad ones are described
    (at most ``keep`` of them) and counted."""

    def __init__(self, env, keep: int = 10):
        self.checked = 0
        self.contains_checked = 0
        self.bad = 0
        self.examples: list[str] = []
        self.keep = keep
        self.use(env)

    def use(self, env) -> None:
        """Check the observations of ``env`` from now on."""
        self.spaces = {a: env.observation_space(a) for a in env.possible_agents}
        space = self.spaces[env.possible_agents[0]]
        self.fast = (
            isinstance(space, gymnasium.spaces.Box)
            and all(s == space for s in self.spaces.values())
            and np.issubdtype(space.dtype, np.floating)
        )
        if self.fast:
            self.shape, self.dtype = space.shape, space.dtype
            self.low, self.high = space.low, space.high
            self.uniform = bool(
                self.low.min() == self.low.max() and self.high.min() == self.high.max()
            )
            self.lo, self.hi = float(self.low.min()), float(self.high.max())

    def __call__(self, observations: dict, where: str, contains: bool = False) -> None:
        self.checked += len(observations)
        if contains or not self.fast or not self._in_bounds(observations):
            self.contains_checked += len(observations)
            for agent, obs in observations.items():
                problem = self._problem(agent, obs)
                if problem is not None:
                    self.bad += 1
                    if len(self.examples) < self.keep:
                        self.examples.append(f"{where}, {agent}: {problem}")

    def _in_bounds(self, observations: dict) -> bool:
        values = list(observations.values())
        for obs in values:
            if (
                not isinstance(obs, np.ndarray)
                or obs.shape != self.shape
                or obs.dtype != self.dtype
            ):
                return False
        x = np.stack(values)
        if self.uniform:  # a NaN makes both reductions NaN, and the comparisons false
            return bool(np.minimum.reduce(x, axis=None) >= self.lo) and bool(
                np.maximum.reduce(x, axis=None) <= self.hi
            )
        return bool(((x >= self.low) & (x <= self.high)).all())

    def _problem(self, agent: str, obs) -> str | None:
        array = np.asarray(obs)
        if np.issubdtype(array.dtype, np.number) and not np.isfinite(array).all():
            return f"{int((~np.isfinite(array)).sum())} non-finite values"
        if not self.spaces[agent].contains(obs):
            return f"not in {self.spaces[agent]} (range {array.min()}..{array.max()})"
        return None


def step_phase(
    scenario: str,
    agent_steps: int,
    window: int,
    warmup: float,
    seed: int,
    contains_every: int,
    source: str,
) -> tuple[dict, ObservationCheck]:
    env = flatland_ma.parallel_env(scenario)
    check = ObservationCheck(env)
    episode = 0
    observations, _ = env.reset(seed=seed)
    check(observations, "reset 0", contains=True)
    spaces = [env.action_space(a) for a in env.possible_agents]
    for i, space in enumerate(spaces):
        space.seed(seed + i)
    index = {a: i for i, a in enumerate(env.possible_agents)}

    gc.collect()
    rss_start = rss_bytes(source)
    samples = []  # (agent-steps so far, rss, agent-steps/s over the window, per CPU second)
    done = env_steps = 0
    stepping = 0.0  # seconds in the loop, less the sampling (a full collection each)
    window_done, next_sample = 0, window
    started = window_start = time.perf_counter()
    cpu_start = time.process_time()
    while done < agent_steps:
        if not env.agents:
            episode += 1
            observations, _ = env.reset(seed=seed + episode)
            check(observations, f"reset {episode}", contains=True)
        actions = {a: spaces[index[a]].sample() for a in env.agents}
        observations, *_ = env.step(actions)
        env_steps += 1
        done += len(actions)
        check(observations, f"step {env_steps}", contains=env_steps % contains_every == 0)
        if done >= next_sample or done >= agent_steps:
            spent = time.perf_counter() - window_start
            stepping += spent
            rate = (done - window_done) / spent
            cpu_rate = (done - window_done) / max(time.process_time() - cpu_start, 1e-9)
            gc.collect()
            samples.append((done, rss_bytes(source), rate, cpu_rate))
            window_done, next_sample = done, next_sample + window
            window_start, cpu_start = time.perf_counter(), time.process_time()
    elapsed = time.perf_counter() - started
    env.close()

    warm = next(s for s in samples if s[0] >= warmup * agent_steps)
    after = [s for s in samples if s[0] >= warm[0]]
    report = {
        "scenario": scenario,
        "agents": len(env.possible_agents),
        "agent_steps": done,
        "env_steps": env_steps,
        "episodes": episode + 1,
        "seconds": elapsed,
        "warmup_agent_steps": warm[0],
        "rss_start": rss_start,
        "rss_warm": warm[1],
        "rss_end": samples[-1][1],
        "rss_max_after_warmup": max(s[1] for s in after),
        "growth_percent": growth(warm[1], samples[-1][1]),
        "steps_per_s_first": samples[0][2],
        "steps_per_s_warm": warm[2],
        "steps_per_s_last": samples[-1][2],
        "steps_per_s_mean": done / stepping,
        "steps_per_cpu_s_first": samples[0][3],
        "steps_per_cpu_s_last": samples[-1][3],
        "windows": [
            {"agent_steps": s[0], "rss": s[1], "steps_per_s": s[2], "steps_per_cpu_s": s[3]}
            for s in samples
        ],
    }
    return report, check


def creation_phase(
    scenario: str,
    creations: int,
    steps: int,
    warmup: float,
    window: int,
    seed: int,
    source: str,
) -> tuple[dict, ObservationCheck | None]:
    warm_count = max(1, round(warmup * creations))
    check = None
    gc.collect()
    rss_start = rss_bytes(source)
    samples = []  # (creations so far, rss)
    started = time.perf_counter()
    for n in range(1, creations + 1):
        env = flatland_ma.parallel_env(scenario)
        if check is None:
            check = ObservationCheck(env)
        else:
            check.use(env)
        observations, _ = env.reset(seed=seed + n)
        check(observations, f"creation {n} reset", contains=True)
        for i, a in enumerate(env.possible_agents):
            env.action_space(a).seed(seed + n + i)
        for t in range(steps):
            if not env.agents:
                break
            observations, *_ = env.step({a: env.action_space(a).sample() for a in env.agents})
            check(observations, f"creation {n} step {t + 1}", contains=True)
        env.close()
        del env, observations
        if n % window == 0 or n == warm_count or n == creations:
            gc.collect()
            samples.append((n, rss_bytes(source)))
    elapsed = time.perf_counter() - started

    warm = next(s for s in samples if s[0] >= warm_count)
    report = {
        "creations": creations,
        "steps_each": steps,
        "seconds": elapsed,
        "warmup_creations": warm[0],
        "rss_start": rss_start,
        "rss_warm": warm[1],
        "rss_end": samples[-1][1],
        "rss_max_after_warmup": max(s[1] for s in samples if s[0] >= warm[0]),
        "growth_percent": growth(warm[1], samples[-1][1]),
        "creations_per_s": creations / elapsed,
        "windows": [{"creations": s[0], "rss": s[1]} for s in samples],
    }
    return report, check


def growth(before: int, after: int) -> float:
    return 100.0 * (after - before) / before


def run_soak(
    agent_steps: int = 1_000_000,
    creations: int = 500,
    *,
    scenario: str = SCENARIO,
    window: int = 50_000,
    warmup: float = 0.2,
    creation_warmup: float = 0.1,
    creation_steps: int = 5,
    creation_window: int = 10,
    seed: int = 0,
    contains_every: int = 100,
) -> dict:
    """Both phases; the report as a dict (RSS in bytes, rates in agent-steps/s)."""
    source = rss_source()
    steps, check = step_phase(scenario, agent_steps, window, warmup, seed, contains_every, source)
    made, made_check = creation_phase(
        scenario,
        creations,
        creation_steps,
        creation_warmup,
        creation_window,
        seed + 1_000_000,
        source,
    )
    checks = [c for c in (check, made_check) if c is not None]
    return {
        "rss_source": source,
        "steps": steps,
        "creations": made,
        "observations": {
            "checked": sum(c.checked for c in checks),
            "checked_with_contains": sum(c.contains_checked for c in checks),
            "bad": sum(c.bad for c in checks),
            "examples": [e for c in checks for e in c.examples],
        },
    }


def mib(n: int) -> str:
    return f"{n / 2**20:.1f} MiB"


def format_report(report: dict, max_growth: float = MAX_GROWTH) -> str:
    s, c, o = report["steps"], report["creations"], report["observations"]
    rss = "RSS" if report["rss_source"] != "peak" else "peak RSS (no /proc, no psutil)"
    lines = [
        f"soak: {s['scenario']}, {s['agents']} agents",
        f"  agent-steps {s['agent_steps']:,} ({s['env_steps']:,} env steps, "
        f"{s['episodes']} episodes) in {s['seconds']:.1f} s",
        f"  {rss}: {mib(s['rss_start'])} at start, {mib(s['rss_warm'])} after warm-up "
        f"({s['warmup_agent_steps']:,} agent-steps), {mib(s['rss_end'])} at end "
        f"(max after warm-up {mib(s['rss_max_after_warmup'])})",
        f"  growth after warm-up: {s['growth_percent']:+.2f}% (limit {max_growth}%)",
        f"  agent-steps/s: {s['steps_per_s_first']:,.0f} first window, "
        f"{s['steps_per_s_warm']:,.0f} at warm-up end, {s['steps_per_s_last']:,.0f} last window, "
        f"{s['steps_per_s_mean']:,.0f} overall",
        f"  agent-steps per CPU second (the process's own time, whatever else runs): "
        f"{s['steps_per_cpu_s_first']:,.0f} first window, "
        f"{s['steps_per_cpu_s_last']:,.0f} last window",
        f"creations: {c['creations']} x (create, reset, {c['steps_each']} steps, close) "
        f"in {c['seconds']:.1f} s ({c['creations_per_s']:.1f}/s)",
        f"  {rss}: {mib(c['rss_start'])} before, {mib(c['rss_warm'])} after "
        f"{c['warmup_creations']} warm-up creations, {mib(c['rss_end'])} after all "
        f"(max after warm-up {mib(c['rss_max_after_warmup'])})",
        f"  growth after warm-up: {c['growth_percent']:+.2f}% (limit {max_growth}%)",
        f"observations: {o['checked']:,} checked ({o['checked_with_contains']:,} with "
        f"contains()), {o['bad']} bad",
    ]
    lines += [f"  {e}" for e in o["examples"]]
    return "\n".join(lines)


def failures(report: dict, max_growth: float = MAX_GROWTH) -> list[str]:
    found = []
    if report["observations"]["bad"]:
        found.append(f"{report['observations']['bad']} bad observations")
    for phase in ("steps", "creations"):
        if report[phase]["growth_percent"] >= max_growth:
            found.append(f"{phase}: RSS grew {report[phase]['growth_percent']:.2f}% after warm-up")
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m tests.soak", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--scenario", default=SCENARIO)
    parser.add_argument("--agent-steps", type=int, default=1_000_000)
    parser.add_argument("--creations", type=int, default=500)
    parser.add_argument("--window", type=int, default=50_000, help="agent-steps per sample")
    parser.add_argument("--warmup", type=float, default=0.2, help="share of the steps")
    parser.add_argument("--creation-warmup", type=float, default=0.1, help="share of creations")
    parser.add_argument("--creation-window", type=int, default=10, help="creations per sample")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--contains-every", type=int, default=100, help="env steps")
    parser.add_argument("--max-growth", type=float, default=MAX_GROWTH, help="percent")
    parser.add_argument("--json", help="also write the report to this file")
    args = parser.parse_args(argv)
    report = run_soak(
        args.agent_steps,
        args.creations,
        scenario=args.scenario,
        window=args.window,
        warmup=args.warmup,
        creation_warmup=args.creation_warmup,
        creation_window=args.creation_window,
        seed=args.seed,
        contains_every=args.contains_every,
    )
    print(format_report(report, args.max_growth))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)
    found = failures(report, args.max_growth)
    for problem in found:
        print(f"FAILED: {problem}", file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
