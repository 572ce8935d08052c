"""Evaluation suites: files that say which tasks a policy is judged on, which agents it
drives (the focal ones), and which held-out policies drive the others (the background).

A suite lives in ``scenarios/suites/NAME.yaml`` (``list_suites()``), or any file::

    description: "..."
    training: [greedy]            # partners reserved for training: never background here
    tasks:
      - scenario: plate_relay
        focal: [scout]            # team names or agent names (agent_0, ...)
        background: [planner, random, idle]   # each fills every other slot in turn
        scripted: [planner]       # the best of these as focal scores 1 (random play 0)
        episodes: 3               # per background policy, seeds seed, seed + 1, ...

A policy is a shipped one's name (``flatland_ma.policies.named.SHIPPED``) or a
checkpoint's path. Faults are reported with the file, line and key path, as scenario
files' are.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Annotated, Any

from pydantic import Field, ValidationError, model_validator

from flatland_ma.scenario.errors import Marks, ScenarioError, SpecError
from flatland_ma.scenario.loader import file_text
from flatland_ma.scenario.messages import problems_from
from flatland_ma.scenario.types import Spec
from flatland_ma.scenario.yaml_reader import parse_yaml

SUITES = "flatland_ma.scenarios"
"""The package whose ``suites`` folder holds the shipped suites."""
PolicyName = Annotated[str, Field(strict=True, min_length=1, max_length=500)]
"""A shipped policy's name or a checkpoint's path."""
AgentOrTeam = Annotated[str, Field(strict=True, pattern=r"^[a-z][a-z0-9_]*$", max_length=40)]


class TaskSpec(Spec):
    """One task of a suite: a scenario, the slots the policy under test drives, and the
    held-out policies that drive the rest."""

    scenario: Annotated[str, Field(strict=True, min_length=1, max_length=500)]
    """A shipped scenario's name or a scenario file's path."""
    focal: Annotated[tuple[AgentOrTeam, ...], Field(min_length=1, max_length=64)]
    """The agents the policy under test drives: team names or agent names."""
    background: Annotated[tuple[PolicyName, ...], Field(min_length=1, max_length=16)]
    """Policies that drive every other agent, one after another (each for ``episodes``)."""
    scripted: Annotated[tuple[PolicyName, ...], Field(min_length=1, max_length=8)]
    """Policies tried in the focal slots: the best one's mean return is the score 1."""
    episodes: Annotated[int, Field(strict=True, ge=1, le=1000)] = 3
    """Episodes per background policy (seeds ``seed``, ``seed + 1``, ...)."""
    overrides: dict[str, Any] = {}
    """Keyword overrides of the scenario, as ``load_scenario`` takes them."""


class SuiteSpec(Spec):
    description: Annotated[str, Field(strict=True, max_length=1000)] = ""
    """What the suite measures."""
    training: Annotated[tuple[PolicyName, ...], Field(max_length=64)] = ()
    """Partners reserved for training: no task may use them as background."""
    tasks: Annotated[tuple[TaskSpec, ...], Field(min_length=1, max_length=256)]
    """The tasks, each scored and reported on its own and aggregated."""

    @model_validator(mode="after")
    def _held_out(self):
        for t, task in enumerate(self.tasks):
            for b, name in enumerate(task.background):
                if name in self.training:
                    raise SpecError(
                        ("tasks", t, "background", b),
                        f"{name!r} is reserved for training ('training'): evaluation "
                        "partners must be held out",
                    )
        return self

    def backgrounds(self) -> set[str]:
        """Every background policy of every task."""
        return {name for task in self.tasks for name in task.background}


def suite_dir() -> Path:
    return Path(str(resources.files(SUITES))) / "suites"


def list_suites() -> list[str]:
    """Names of the shipped suites, sorted."""
    return sorted(p.stem for p in suite_dir().glob("*.yaml"))


def load_suite(name: str | Path) -> SuiteSpec:
    """A shipped suite by name, or a suite file; ``ScenarioError`` (file, line, key path)
    if it is not a valid suite."""
    path = Path(name)
    if not path.suffix:
        if str(name) not in list_suites():
            raise ValueError(f"no suite {str(name)!r}; suites: {', '.join(list_suites())}")
        path = suite_dir() / f"{name}.yaml"
    if not path.is_file():
        raise FileNotFoundError(f"no suite file {path}")
    marks: Marks = {}
    raw = parse_yaml(file_text(path), str(path), marks)
    try:
        return SuiteSpec.model_validate(raw)
    except ValidationError as err:
        raise ScenarioError(problems_from(err.errors(), SuiteSpec, raw, marks, str(path))) from None
