"""The benchmark's settings (``settings.yaml`` beside this file): seeds, held-out episodes, the
open-loop baseline's search, and the tiers of PPO: each tier's seeds, the tasks it runs and
each task's budget, options and the name of that configuration. Read strictly: an unknown
key, a wrong type, a PPO option the learner does not take, an unknown preset or a
curriculum whose stages do not add up to the budget fails at load, naming the file and the
key."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

METHODS = ("random", "scripted", "open_loop", "ppo", "ppo_no_channel")
"""The methods, in the order ``make benchmark`` runs them (the cheap ones first)."""

LEARNED = frozenset({"ppo", "ppo_no_channel"})
"""Methods whose results belong to a tier (a budget of training); the others play the same
way in every tier, and their results serve every tier."""

NO_CHANNEL = "ppo_no_channel"
"""The channel's ablation: PPO in the task's own configuration of the tier, trained and
scored without the scenario's channel (``baselines.ppo --no-channel``), on every scenario
that has one: what PPO makes of the channel is PPO's score above this."""

CHANNEL_BIASES = frozenset({"listening", "signalling"})
"""PPO options that bias the use of the channel (``baselines.channel_bias``): its ablation
trains without them."""

TIERS = ("smoke", "standard", "certificate")
"""The tiers, in the order of their budgets (the page's order)."""

Tier = Literal["smoke", "standard", "certificate"]
Count = Annotated[int, Field(strict=True, ge=1)]
ROOT = Path(__file__).resolve().parents[2]
"""The checkout: results, runs and curricula are found from it."""
SETTINGS = Path(__file__).resolve().parent / "settings.yaml"
"""The shipped settings."""


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


class TaskConfig(Strict):
    """PPO on one task: its budget, the options given to the learner and their name."""

    budget: Count
    """Agent-steps of training per seed (a stream: its whole life, scaled to this)."""
    name: str = "defaults"
    """The configuration's name, as results and the page give it (e.g. "curriculum, team
    reward, shaping 3")."""
    ppo: dict[str, Any] = {}
    """Options of ``baselines.ppo.Args`` (a scenario) or ``baselines.lifelong.Args`` (a
    stream), by field name, e.g. ``{num_envs: 8}``."""


class TaskOverride(Strict):
    budget: Count | None = None
    name: str | None = None
    """Required when ``ppo`` is given: other options are another configuration."""
    ppo: dict[str, Any] = {}
    """Merged over the default's options."""


class TierConfig(Strict):
    """One tier of PPO runs: seeds, budgets and options per task."""

    seeds: Annotated[int, Field(strict=True, ge=1, le=100)] = 3
    """PPO's seeds on every task of the tier."""
    only: list[str] | None = None
    """The tasks the tier runs PPO on (e.g. the certificate's: those still open at the
    standard budget); none: every task."""
    default: TaskConfig
    """Every task's PPO, unless ``tasks`` says otherwise."""
    tasks: dict[str, TaskOverride] = {}

    def task(self, name: str, method: str = "ppo") -> TaskConfig:
        """PPO's configuration on task ``name`` (``NO_CHANNEL``: the same without the
        scenario's channel)."""
        override = self.tasks.get(name)
        task = self.default
        if override is not None:
            task = TaskConfig(
                budget=override.budget or self.default.budget,
                name=override.name or self.default.name,
                ppo={**self.default.ppo, **override.ppo},
            )
        if method == NO_CHANNEL:  # the channel's biases go with it
            kept = {k: v for k, v in task.ppo.items() if k not in CHANNEL_BIASES}
            biased = " and its biases" if len(kept) < len(task.ppo) else ""
            return TaskConfig(
                budget=task.budget,
                name=f"{task.name}, without the channel{biased}",
                ppo={**kept, "no_channel": True},
            )
        return task

    def runs(self, name: str) -> bool:
        """Whether the tier trains PPO on task ``name``."""
        return self.only is None or name in self.only


class OpenLoopConfig(Strict):
    """The open-loop baseline's search (``baselines.open_loop``)."""

    candidates: Count = 32
    """Action sequences drawn per seed (and per task of a stream)."""
    episodes: Count = 3
    """Training episodes each candidate is scored on (seeded apart from the held-out ones)."""
    hold: Count = 16
    """Each action of a sequence is held for 1 to this many steps (uniformly drawn)."""


class BenchmarkConfig(Strict):
    seeds: Annotated[int, Field(strict=True, ge=1, le=100)] = 3
    """Seeds of random, scripted and open-loop play on every task (PPO: its tier's)."""
    episodes: Annotated[int, Field(strict=True, ge=1, le=1000)] = 10
    """Held-out episodes each seed of each method is scored on (a stream: per task)."""
    eval_seed: Annotated[int, Field(strict=True, ge=0)] = 100_000
    """A scenario's held-out episodes are reset with eval_seed, eval_seed + 1, ..."""
    never_ending_steps: Count = 1000
    """The never-ending stream is scored on its first this many steps."""
    open_loop: OpenLoopConfig = OpenLoopConfig()
    tiers: dict[Tier, TierConfig]
    """PPO's tiers; ``smoke`` is required (its results are the ones without a tier)."""

    def tier(self, name: str) -> TierConfig:
        if name not in self.tiers:
            raise ValueError(
                f"no tier {name!r} in the benchmark's settings: {', '.join(self.tiers)}"
            )
        return self.tiers[name]  # type: ignore[index]

    def task(self, name: str, tier: str = "smoke", method: str = "ppo") -> TaskConfig:
        return self.tier(tier).task(name, method)


def _check_options(config: BenchmarkConfig, source: str) -> None:
    from baselines import lifelong, ppo
    from baselines.ppo_presets import PRESETS

    fields = {f.name for f in dataclasses.fields(lifelong.Args)} | {
        f.name for f in dataclasses.fields(ppo.Args)
    }
    fixed = {"scenario", "stream", "seed", "total_timesteps", "csv", "out", "scale", "method"}
    for tier_name, tier in config.tiers.items():
        entries = [(f"tiers.{tier_name}.default", tier.default.ppo, tier.default.budget)] + [
            (f"tiers.{tier_name}.tasks.{name}", t.ppo, t.budget or tier.default.budget)
            for name, t in tier.tasks.items()
        ]
        for where, options, budget in entries:
            for key in options:
                if key not in fields or key in fixed:
                    raise ValueError(
                        f"{source}: {where}.ppo.{key}: not an option the benchmark passes to "
                        "baselines.ppo / baselines.lifelong"
                    )
            preset = options.get("preset")
            if preset and preset not in PRESETS:
                raise ValueError(f"{source}: {where}.ppo.preset: no preset {preset!r}")
            if options.get("curriculum"):
                _check_curriculum(options["curriculum"], budget, f"{source}: {where}.ppo")
        for name, override in tier.tasks.items():
            if override.ppo and not override.name:
                raise ValueError(
                    f"{source}: tiers.{tier_name}.tasks.{name}.name: options of its own are "
                    "another configuration; name it"
                )


def _check_curriculum(path: str, budget: int, where: str) -> None:
    from baselines.curriculum import curriculum_stages

    steps = sum(s.steps for s in curriculum_stages(curriculum_path(path)))
    if steps != budget:
        raise ValueError(
            f"{where}.curriculum: its stages add up to {steps:,} agent-steps, not the "
            f"budget's {budget:,}"
        )


def curriculum_path(path: str) -> Path:
    """A curriculum's file, relative to the checkout unless absolute."""
    return Path(path) if Path(path).is_absolute() else ROOT / path


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
    if "smoke" not in config.tiers:
        raise ValueError(f"{path}: tiers.smoke: required (the results without a tier)")
    _check_options(config, str(path))
    return config
