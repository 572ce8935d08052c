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
files' are, and every reference is resolved when the file loads, before any task plays:
each task's scenario with its overrides (loaded and checked as the envs build it), its
focal names (agents or teams, leaving background slots), and every policy (a shipped one
made for each agent it drives; a checkpoint that is a regular file, made likewise).
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

from pydantic import Field, PrivateAttr, ValidationError, model_validator

from flatland_ma.policies.references import (
    check_policy,
    check_policy_name,
    focal_indices,
    scenario_of,
)
from flatland_ma.scenario.errors import Marks, ScenarioError, SpecError, locate
from flatland_ma.scenario.loader import file_text
from flatland_ma.scenario.messages import problems_from
from flatland_ma.scenario.types import FileSpec, Spec
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


class SuiteSpec(FileSpec):
    description: Annotated[str, Field(strict=True, max_length=1000)] = ""
    """What the suite measures."""
    training: Annotated[tuple[PolicyName, ...], Field(max_length=64)] = ()
    """Partners reserved for training: no task may use them as background."""
    tasks: Annotated[tuple[TaskSpec, ...], Field(min_length=1, max_length=256)]
    """The tasks, each scored and reported on its own and aggregated."""
    _origin: tuple[str, Marks] = PrivateAttr(default=("<suite>", {}))
    """As ``FileSpec``'s, named ``<suite>`` until it is read from a file."""

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

    def fault(self, path: tuple, message: str) -> ScenarioError:
        """A fault at ``path`` of this suite, located in its file (file, line, key path)."""
        return ScenarioError([locate(self.marks, path, message, self.source)])


def suite_dir() -> Path:
    return Path(str(resources.files(SUITES))) / "suites"


def list_suites() -> list[str]:
    """Names of the shipped suites, sorted."""
    return sorted(p.stem for p in suite_dir().glob("*.yaml"))


def load_suite(name: str | Path) -> SuiteSpec:
    """A shipped suite by name, or a suite file; ``ScenarioError`` (file, line, key path)
    if it is not a valid suite or one of its references does not resolve (see the module's
    docstring), or if the file is no regular file (``flatland_ma.scenario.files``)."""
    path = Path(name)
    if not path.suffix and not os.path.lexists(path):
        if str(name) not in list_suites():
            raise ValueError(f"no suite {str(name)!r}; suites: {', '.join(list_suites())}")
        path = suite_dir() / f"{name}.yaml"
    source = str(path)
    marks: Marks = {}
    raw = parse_yaml(file_text(path), source, marks)
    try:
        suite = SuiteSpec.model_validate(raw)
    except ValidationError as err:
        raise ScenarioError(problems_from(err.errors(), SuiteSpec, raw, marks, source)) from None
    suite.read_from(source, marks)
    resolve(suite, path)
    return suite


def resolve(suite: SuiteSpec, file: Path | None = None) -> None:
    """Resolve every reference of ``suite`` (its file is ``file``), task by task in order;
    ``ScenarioError`` located at the first that does not resolve."""
    from flatland_ma.envs.parallel import FlatlandParallelEnv

    for k, name in enumerate(suite.training):
        try:
            check_policy_name(name, ("training", k))
        except SpecError as err:
            raise suite.fault(err.path, str(err)) from None
    for t, task in enumerate(suite.tasks):
        try:
            scenario = scenario_of(task.scenario, task.overrides, file)
            focal = focal_indices(scenario, task.focal, task.scenario)
            env = FlatlandParallelEnv(scenario)
            try:
                mine = [env.possible_agents[i] for i in focal]
                others = [a for a in env.possible_agents if a not in mine]
                for b, policy in enumerate(task.background):
                    check_policy(policy, env, others, ("background", b))
                for k, policy in enumerate(task.scripted):
                    check_policy(policy, env, mine, ("scripted", k))
            finally:
                env.close()
        except SpecError as err:
            raise suite.fault(("tasks", t, *err.path), str(err)) from None
