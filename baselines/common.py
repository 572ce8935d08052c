"""Pieces every baseline shares: the scenario's counters, seeding, the timed env, the
evaluation after training, the paper's conv trunk (from ``flatland_ma.policies.networks``,
where the networks checkpoints hold are defined), input normalisation, and the per-run
CSV log. Each algorithm's ``Args`` dataclass is turned into flags by ``tyro.cli``.

A run writes ``<csv>.part`` while it trains, one row per finished episode and agent
(``FIXED_COLUMNS`` around the scenario's counters), and renames it to ``<csv>`` when it
completes; beside it a JSON file records the arguments, the counters, the steps done, the
wall time and the seconds spent inside the environment. ``baselines.run`` resumes by
skipping seeds whose CSV exists.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import numbers
import os
import random
import resource
import time
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import torch

import flatland_ma
from flatland_ma.envs.registration import gym_id

# The paper's trunk and Keras' initialisation, for the baselines that import them from here.
from flatland_ma.policies.networks import (  # noqa: F401
    CONV_CHANNELS,
    CONV_KERNELS,
    conv_trunk,
    keras_init,
    trunk_length,
)

FIXED_COLUMNS = ("seed", "episode", "step", "agent", "return", "wall_time")
"""Every run's CSV columns; the scenario's counters go between ``return`` and ``wall_time``.
One row per finished episode and agent; ``step`` counts agent-steps since the start."""


# -- the scenario's counters ------------------------------------------------------------


def info_counters(info: dict) -> tuple[str, ...]:
    """The names of an agent's episode counters: every entry of its info that holds a number
    (``score``, one count per item group, ``deliveries`` where present), in the info's order.
    Anything else is skipped, such as ``keys`` (the tuple of the keys held, in scenarios with
    keys): its item group's own count already says how many keys were picked up."""
    return tuple(name for name, value in info.items() if isinstance(value, numbers.Real))


def counters_text(info: dict, names: tuple[str, ...]) -> str:
    """``score=160 fruits=17 poisons=1``, for the console."""
    return " ".join(f"{name}={_cell(info[name])}" for name in names)


def _keep_rows(source: Path, part: Path, agent_steps: int, header: list[str]) -> int:
    """Write to ``part`` the header and the rows of the log ``source`` of episodes that
    ended by ``agent_steps`` (a row cut short by the interruption is dropped); the number
    of episodes kept (the next episode's index). ``ValueError`` naming the file, before
    anything is written, if it is not a log of ``header``'s columns."""
    try:
        with open(source, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        raise ValueError(f"{source}: not a log this run can go on with ({err})") from None
    if not rows or rows[0] != header:
        raise ValueError(f"{source}: not a log this run can go on with (other columns)")

    def ended_by(row: list[str]) -> bool:
        whole = len(row) == len(header) and row[-1].count(".") == 1  # wall_time: %.2f
        return whole and row[1].isdigit() and row[2].isdigit() and int(row[2]) <= agent_steps

    kept = [r for r in rows[1:] if ended_by(r)]
    with open(part, "w", newline="") as f:
        csv.writer(f).writerows([header, *kept])
    return 1 + max((int(r[1]) for r in kept), default=-1)


def _cell(value) -> str:
    """A counter as the CSV writes it: integers as they are, other numbers as ``%g``."""
    return str(int(value)) if isinstance(value, numbers.Integral) else f"{float(value):g}"


# -- seeding and the environment ---------------------------------------------------------


def seed_everything(seed: int) -> None:
    """Fix Python's, numpy's and torch's generators, and run torch on one thread."""
    random.seed(seed)
    np.random.seed(seed)  # noqa: NPY002 - the legacy global generator, for any code using it
    torch.manual_seed(seed)
    torch.set_num_threads(1)


class TimedEnv(gymnasium.Wrapper):
    """Counts the wall-clock seconds spent inside ``reset`` and ``step``."""

    def __init__(self, env: gymnasium.Env):
        super().__init__(env)
        self.seconds = 0.0

    def reset(self, **kwargs):
        start = time.perf_counter()
        out = self.env.reset(**kwargs)
        self.seconds += time.perf_counter() - start
        return out

    def step(self, action):
        start = time.perf_counter()
        out = self.env.step(action)
        self.seconds += time.perf_counter() - start
        return out


def make_env(scenario: str) -> TimedEnv:
    """The Gymnasium env of a single-agent scenario, timed: ``key_door`` is
    ``flatland_ma/KeyDoor-v0`` (its id names its version), registered when flatland_ma is
    imported."""
    env_id = gym_id(scenario) if scenario in flatland_ma.list_scenarios() else None
    if env_id not in flatland_ma.GYM_IDS:
        raise ValueError(
            f"{scenario!r} has no Gymnasium id (a multi-agent scenario, or no scenario); "
            f"the single-agent ones: {', '.join(flatland_ma.GYM_IDS)}"
        )
    return TimedEnv(gymnasium.make(env_id))


EVAL_SEED = 1_000_000
"""Evaluation after training resets its own env with ``EVAL_SEED + seed``: item positions
that training, seeded with ``seed``, never drew in that order."""


def evaluate_policy(scenario: str, act, episodes: int, seed: int, epsilon: float = 0.0) -> dict:
    """Play ``episodes`` full episodes of ``act(observation, info) -> action`` on a fresh env,
    replacing the action by a uniformly random one with probability ``epsilon``.

    Returns the mean return, the mean of each of the scenario's counters at the episodes'
    ends, every return, the epsilon and the seconds it took (kept out of the training wall
    time)."""
    start = time.perf_counter()
    env = make_env(scenario)
    rng = np.random.default_rng(EVAL_SEED + seed)
    n_actions = int(env.action_space.n)
    returns, finals = [], []
    observation, info = env.reset(seed=EVAL_SEED + seed)
    names = info_counters(info)
    for _ in range(episodes):
        total, done = 0.0, False
        while not done:
            action = act(observation, info)
            if rng.random() < epsilon:
                action = int(rng.integers(n_actions))
            observation, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            done = terminated or truncated
        returns.append(total)
        finals.append([float(info[name]) for name in names])
        observation, info = env.reset()
    env.close()
    return {
        "episodes": episodes,
        "return": float(np.mean(returns)),
        "counters": dict(zip(names, map(float, np.mean(finals, axis=0)))),
        "returns": returns,
        "epsilon": epsilon,
        "seconds": round(time.perf_counter() - start, 2),
    }


def evaluate_after_training(args, act) -> dict | None:
    """``evaluate_policy`` with a run's ``eval_episodes`` and ``eval_epsilon`` (None when
    ``eval_episodes`` is 0); prints the mean return."""
    if not args.eval_episodes:
        return None
    evaluation = evaluate_policy(
        args.scenario, act, args.eval_episodes, args.seed, args.eval_epsilon
    )
    print(
        f"after training (epsilon {args.eval_epsilon:g}): mean return "
        f"{evaluation['return']:g} over {args.eval_episodes} episodes",
        flush=True,
    )
    return evaluation


def input_channels(use_depth: bool) -> int:
    """RGB, plus depth when asked: the paper's DQN input is the (64, 3) colour image."""
    return 4 if use_depth else 3


def to_input(observation: np.ndarray, use_depth: bool) -> np.ndarray:
    """(rays, 4) observation -> (channels, rays) float32, the layout of ``nn.Conv1d``."""
    return np.ascontiguousarray(observation[..., : input_channels(use_depth)].swapaxes(-1, -2))


# -- networks ----------------------------------------------------------------------------


class RunningNormalizer:
    """Per-element running mean and standard deviation of the inputs, as keras-rl's
    ``WhiteningNormalizerProcessor`` (standard deviation floored at ``eps``)."""

    def __init__(self, shape: tuple[int, ...], eps: float = 1e-2):
        self.count = 0
        self.sum = torch.zeros(shape, dtype=torch.float64)
        self.sum_squares = torch.zeros(shape, dtype=torch.float64)
        self.mean = torch.zeros(shape)
        self.std = torch.ones(shape)
        self.eps = eps

    def update(self, x: torch.Tensor) -> None:
        """Add one input (or a batch along the first axis) to the statistics."""
        x = x.reshape(-1, *self.sum.shape).double()
        self.count += x.shape[0]
        self.sum += x.sum(0)
        self.sum_squares += x.square().sum(0)
        mean = self.sum / self.count
        variance = (self.sum_squares / self.count - mean.square()).clamp(min=self.eps**2)
        self.mean, self.std = mean.float(), variance.sqrt().float()

    def __call__(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.mean) / self.std


# -- the run log -------------------------------------------------------------------------


def default_csv(algorithm: str, scenario: str, seed: int) -> str:
    return f"runs/{algorithm}/{scenario}/seed_{seed}.csv"


class RunLog:
    """Writes episode rows to ``<csv>.part`` as they finish; ``close`` renames it to
    ``<csv>`` and writes the run's summary to ``<csv without .csv>.json``. ``counters``
    (from ``info_counters`` on an info at reset) are the columns between ``return`` and
    ``wall_time``, read from each finished episode's info. ``going_on``: (agent-steps,
    wall seconds) of an interrupted run to go on with (``baselines.ppo_resume``): its
    ``.part`` keeps the rows up to those agent-steps, and the wall clock goes on."""

    def __init__(
        self,
        algorithm: str,
        csv_path: str,
        seed: int,
        args,
        counters: tuple[str, ...],
        going_on: tuple[int, float] | None = None,
    ):
        clashes = set(counters) & set(FIXED_COLUMNS)
        if clashes:
            raise ValueError(f"counters named like the log's own columns: {sorted(clashes)}")
        self.counters = tuple(counters)
        self.path = Path(csv_path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.part = self.path.with_name(self.path.name + ".part")
        self.algorithm, self.seed, self.args = algorithm, seed, args
        self.start = time.perf_counter()
        self.episodes = 0
        header = [*FIXED_COLUMNS[:-1], *self.counters, FIXED_COLUMNS[-1]]
        # The interrupted run's log; or a finished run's, asked to go on.
        source = self.part if self.part.is_file() else self.path
        if going_on is not None and source.is_file():
            self.episodes = _keep_rows(source, self.part, going_on[0], header)
            if source != self.part:
                source.unlink()
            self.start -= going_on[1]
            self.file = open(self.part, "a", newline="")
            self.writer = csv.writer(self.file)
            return
        self.file = open(self.part, "w", newline="")
        self.writer = csv.writer(self.file)
        self.writer.writerow(header)
        self.file.flush()

    def episode(
        self,
        step: int,
        episode_return: float,
        info: dict,
        agent: str = "agent_0",
        episode: int | None = None,
    ) -> None:
        """One finished episode of one agent; ``episode`` defaults to a running count."""
        if episode is None:
            episode = self.episodes
            self.episodes += 1
        wall = time.perf_counter() - self.start
        self.writer.writerow(
            [
                self.seed,
                episode,
                step,
                agent,
                f"{episode_return:g}",
                *(_cell(info[name]) for name in self.counters),
                f"{wall:.2f}",
            ]
        )
        self.file.flush()

    def close(
        self,
        steps: int,
        env_seconds: float,
        busy_seconds: float | None = None,
        evaluation: dict | None = None,
        extra: dict | None = None,
    ) -> dict:
        """Finish the run. ``busy_seconds`` is the time ``env_seconds`` is a share of
        (by default the run's wall time; summed over processes for A3C). ``evaluation``
        (from ``evaluate_policy``) is stored as is; its seconds are not training time.
        ``extra`` (e.g. the CPU time and the machine's load) joins the summary."""
        wall = time.perf_counter() - self.start - (evaluation or {}).get("seconds", 0.0)
        busy = wall if busy_seconds is None else busy_seconds
        summary = {
            "algorithm": self.algorithm,
            "args": dataclasses.asdict(self.args),
            "counters": list(self.counters),
            "steps": steps,
            "wall_seconds": round(wall, 2),
            "env_seconds": round(env_seconds, 2),
            "env_share": round(env_seconds / max(busy, 1e-9), 4),
            "torch_threads": torch.get_num_threads(),
            "cpu": _cpu_name(),
        }
        if evaluation is not None:
            summary["evaluation"] = evaluation
        summary.update(extra or {})
        self.file.close()
        self.path.with_suffix(".json").write_text(json.dumps(summary, indent=2) + "\n")
        os.replace(self.part, self.path)
        return summary


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def cpu_seconds() -> float:
    """CPU time of this process (every thread: torch's and numba's) and of its finished
    children (the shards' workers, once closed)."""
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def calibration(rounds: int = 20) -> float:
    """A fixed piece of work's rate (256 x 256 matrix products per CPU-second on this
    thread): how fast the machine was while the figures were taken."""
    a = torch.ones(256, 256)
    start = time.thread_time()
    for _ in range(rounds):
        a = (a @ a).clamp_(max=1.0)
    return rounds / (time.thread_time() - start)


def threads_used(asked: int) -> dict:
    """The threads torch and the ray kernel use at the end of a run; warns if torch's
    differ from what the run asked for."""
    import numba

    used = {
        "torch": torch.get_num_threads(),
        "torch_asked": asked,
        "kernel": numba.get_num_threads(),
    }
    if used["torch"] != asked:
        warnings.warn(f"torch ran on {used['torch']} threads, not the {asked} asked", stacklevel=2)
    return used
