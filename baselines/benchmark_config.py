"""The benchmark's settings (``baselines/benchmark.yaml``): seeds, held-out episodes, and
each task's PPO budget and options. Read strictly: an unknown key, a wrong type or a PPO
option the learner does not take fails at load, naming the file and the key."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated, Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

METHODS = ("random", "scripted", "ppo")
"""The methods, in the order ``make benchmark`` runs them (the cheap ones first)."""

Count = Annotated[int, Field(strict=True, ge=1)]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


class TaskConfig(Strict):
    """PPO on one task: its budget and the options given to the learner."""

    budget: Count
    """Agent-steps of training per seed (a stream: its whole life, scaled to this)."""
    ppo: dict[str, Any] = {}
    """Options of ``baselines.ppo.Args`` (a scenario) or ``baselines.lifelong.Args`` (a
    stream), by field name, e.g. ``{num_envs: 8}``."""


class TaskOverride(Strict):
    budget: Count | None = None
    ppo: dict[str, Any] = {}
    """Merged over the default's options."""


class BenchmarkConfig(Strict):
    seeds: Annotated[int, Field(strict=True, ge=1, le=100)] = 3
    """Seeds of every method on every task."""
    episodes: Annotated[int, Field(strict=True, ge=1, le=1000)] = 10
    """Held-out episodes each seed of each method is scored on (a stream: per task)."""
    eval_seed: Annotated[int, Field(strict=True, ge=0)] = 100_000
    """A scenario's held-out episodes are reset with eval_seed, eval_seed + 1, ..."""
    never_ending_steps: Count = 1000
    """The never-ending stream is scored on its first this many steps."""
    default: TaskConfig
    """Every task's PPO, unless ``tasks`` says otherwise."""
    tasks: dict[str, TaskOverride] = {}

    def task(self, name: str) -> TaskConfig:
        override = self.tasks.get(name)
        if override is None:
            return self.default
        return TaskConfig(
            budget=override.budget or self.default.budget,
            ppo={**self.default.ppo, **override.ppo},
        )


def _check_options(config: BenchmarkConfig, source: str) -> None:
    from baselines import lifelong, ppo

    fields = {f.name for f in dataclasses.fields(lifelong.Args)} | {
        f.name for f in dataclasses.fields(ppo.Args)
    }
    fixed = {"scenario", "stream", "seed", "total_timesteps", "csv", "out", "scale", "method"}
    entries = [("default", config.default.ppo)] + [
        (f"tasks.{name}", t.ppo) for name, t in config.tasks.items()
    ]
    for where, options in entries:
        for key in options:
            if key not in fields or key in fixed:
                raise ValueError(
                    f"{source}: {where}.ppo.{key}: not an option the benchmark passes to "
                    "baselines.ppo / baselines.lifelong"
                )


def load_config(path: str | Path) -> BenchmarkConfig:
    text = Path(path).read_text(encoding="utf-8")
    data = yaml.safe_load(text)
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a benchmark config is a mapping")
    try:
        config = BenchmarkConfig.model_validate(data)
    except ValidationError as error:
        lines = [
            f"{path}: {'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in error.errors()
        ]
        raise ValueError("\n".join(lines)) from None
    _check_options(config, str(path))
    return config
