"""The benchmark's PPO: ``baselines.ppo`` on a scenario and ``baselines.lifelong --method
finetune`` through a stream of tasks, each for its task's budget of agent-steps (the
never-ending stream goes through ``baselines.never_ending``, from ``runs.run_one``)."""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

from baselines.benchmark.settings import NO_CHANNEL, TaskConfig, curriculum_path

RESUME_EVERY = 100
"""Updates between the checkpoints an interrupted run goes on from (200k agent-steps of
16 one-agent worlds)."""


def train_scenario(
    name: str, seed: int, task: TaskConfig, runs: Path, method: str = "ppo"
) -> tuple[str, int, dict]:
    """``baselines.ppo`` on scenario ``name`` for the task's budget, its log and checkpoints
    under ``runs/<name>/<method>/``: (checkpoint, agent-steps, and for a run that went on
    from an interrupted one, ``resumed_at`` and the ``earlier_seconds`` of CPU and wall
    time its earlier processes spent)."""
    from baselines import ppo
    from baselines.ppo_resume import prune
    from flatland_ma.policies.checkpoint import SUFFIX

    log = runs / name / method / f"seed_{seed}.csv"
    args = ppo_args(name, seed, task, log)
    summary = ppo.main(args)
    prune(log.with_suffix(""), -1)  # the run is over: nothing left to go on from
    resumed = {k: summary[k] for k in ("resumed_at", "earlier_seconds") if k in summary}
    return str(log.with_suffix(SUFFIX)), int(summary["steps"]), resumed


def ppo_args(name: str, seed: int, task: TaskConfig, log: Path):
    """``baselines.ppo``'s arguments for a task: its options, the budget and the log. A
    preset's settings are applied here, beneath the task's own options, and the budget
    then set (a preset that names a length of run would otherwise replace a budget equal
    to the learner's default); a curriculum's file is found from the checkout. The run
    keeps its newest checkpoint of every ``RESUME_EVERY`` updates and goes on from it if
    it was interrupted (``baselines.ppo_resume``)."""
    from baselines import ppo
    from baselines.ppo_presets import with_preset

    options = {
        "tensorboard": False,
        "checkpoint_every": RESUME_EVERY,
        "keep_checkpoints": 1,
        "resume": True,
        **task.ppo,
    }
    if options.get("curriculum"):
        options["curriculum"] = str(curriculum_path(options["curriculum"]))
    args = with_preset(ppo.Args(scenario=name, seed=seed, csv=str(log), **options))
    return dataclasses.replace(args, preset="", total_timesteps=task.budget)


def train_stream(name: str, seed: int, task: TaskConfig, runs: Path, config) -> tuple[dict, int]:
    """``baselines.lifelong --method finetune`` through stream ``name``, its life scaled to
    the task's budget, with one evaluation block at the start and one at the end: (each
    task's mean return in the last block, agent-steps)."""
    from baselines import lifelong
    from flatland_ma.lifelong import load_stream

    stream = load_stream(name)
    if stream.never_ending:
        raise ValueError(f"{name}: baselines.lifelong lives only streams of tasks")
    length = stream.length
    assert length is not None
    out = runs / name
    options = {"tensorboard": False, **task.ppo}
    args = lifelong.Args(
        stream=name,
        method="finetune",
        seed=seed,
        out=str(out),
        scale=task.budget / length,
        eval_every=10 * task.budget,
        eval_episodes=config.episodes,
        **options,
    )
    summary = lifelong.main(args)
    with open(out / "finetune" / f"seed_{seed}" / "evaluations.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    last = max(int(r["step"]) for r in rows)
    labels = stream.task_labels
    parts = {
        labels[int(r["task"])]: float(r["mean_return"]) for r in rows if int(r["step"]) == last
    }
    return parts, int(summary["agent_steps"])


def never_ending(name: str) -> bool:
    from flatland_ma.lifelong import load_stream

    return bool(load_stream(name).never_ending)


def ppo_possible(name: str, kind: str, method: str = "ppo") -> bool:
    """Whether a shipped learner can train on the task: every scenario and every stream
    (a stream of tasks through ``baselines.lifelong``, the never-ending one through
    ``baselines.never_ending``); the channel's ablation (``NO_CHANNEL``), every scenario
    with a channel."""
    if method == NO_CHANNEL:
        from flatland_ma.scenario.loader import load_scenario

        return kind == "scenario" and load_scenario(name).channel is not None
    return kind in ("scenario", "stream")
