"""What was tried on a task beyond its benchmark configuration, and what blocks it: read
from ``results/tried.yaml`` (written by hand after each study, naming the page that holds
its runs) and shown on the task's scenario page."""

from __future__ import annotations

import datetime
import os
from pathlib import Path

import yaml
from pages import table
from pydantic import BaseModel, ConfigDict, Field

ROOT = Path(__file__).resolve().parents[2]
TRIED = ROOT / "results" / "tried.yaml"


class Attempt(BaseModel):
    """One configuration tried on a task: its runs, their result and where they are told."""

    model_config = ConfigDict(extra="forbid", strict=True)
    what: str = Field(min_length=1)
    """The configuration: what it adds to PPO's defaults."""
    agent_steps: int = Field(gt=0)
    """Agent-steps per seed (summed over agents and worlds)."""
    seeds: int = Field(ge=1)
    result: str = Field(min_length=1)
    """What the runs scored, and how it was measured."""
    cpu_seconds: float | None = Field(default=None, ge=0)
    """CPU time per seed, where recorded."""
    date: datetime.date
    where: str = Field(pattern=r"^docs/[a-z_]+\.md(#[a-z0-9-]+)?$")
    """The page (and its section) that gives the runs' commands and figures."""


class Tried(BaseModel):
    """A task's attempts, and what blocks it if it is still open."""

    model_config = ConfigDict(extra="forbid", strict=True)
    tried: list[Attempt] = Field(min_length=1)
    blocks: str | None = None


def load(path: Path = TRIED) -> dict[str, Tried]:
    """Every task's entry; ``ValueError`` (pydantic's, naming the place) for a bad one."""
    if not path.is_file():
        return {}
    raw = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    if not isinstance(raw, dict):
        raise ValueError(f"{path}: a mapping of task names is required")
    return {str(name): Tried.model_validate(entry) for name, entry in raw.items()}


def tried_section(name: str, page_dir: Path, path: Path = TRIED) -> list[str]:
    """The scenario page's section on what was tried on ``name``, if anything was."""
    entry = load(path).get(name)
    if entry is None:
        return []
    rows = []
    for a in entry.tried:
        page, _, anchor = a.where.partition("#")
        link = os.path.relpath(ROOT / page, page_dir) + (f"#{anchor}" if anchor else "")
        cpu = "" if a.cpu_seconds is None else f"{a.cpu_seconds:.0f} s"
        rows.append(
            [a.what, f"{a.agent_steps:,}", str(a.seeds), a.result, cpu, f"[{a.date}]({link})"]
        )
    out = ["### What was tried", ""]
    out += [
        "Beyond the benchmark's configuration: each row one configuration, its agent-steps "
        "and seeds, what it scored, its CPU time per seed and the page that gives its runs.",
        "",
        table(["Configuration", "Agent-steps", "Seeds", "Result", "CPU", "Runs"], rows),
        "",
    ]
    if entry.blocks:
        out += [f"**What blocks it.** {entry.blocks}", ""]
    return out
