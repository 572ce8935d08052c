"""Task streams: files that say which tasks one life goes through, in which order and for
how long.

A stream lives in ``scenarios/streams/NAME.yaml`` (``list_streams()``), or any file::

    description: "..."
    announce: false            # true: the observation says which task is on
    cycles: 1                  # the list of tasks, this many times over
    eval: {every: 15000, episodes: 4}   # evaluation blocks the baselines run
    tasks:
      - name: fruits           # a label, unique in the stream
        scenario: fruits_poisons
        overrides: {...}       # keyword overrides of the scenario
        steps: 150000          # agent-steps of the learner
        focal: [agent_0]       # the agents the learner drives (default: every agent)
        background: greedy     # the shipped policy that drives every other agent
        until: {mean_return: 5, episodes: 100}   # a curriculum's stage: end it early

or, for the never-ending mode, one world and one episode that never ends while the
items' values and places drift::

    never_ending:
      scenario: fruits_poisons
      drift: {value_step: 0.05, value_bounds: [-1, 1], move: 0.5}

Every task must give the learner the same observation and action spaces: one policy lives
the whole life. Faults are reported with the file, line and key path, as scenario files'
are. Every reference is resolved when the stream loads (``policies.references``): a task's
scenario (a shipped name, or a path read beside the stream file first) with its overrides,
loaded and checked; its focal agents; its background policy, made for every agent it
drives. The file itself is read through ``scenario.files`` (a regular file, a size limit).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

from pydantic import BeforeValidator, Field, ValidationError, model_validator

from flatland_ma.policies.references import check_policy, focal_indices, scenario_of
from flatland_ma.scenario.errors import Marks, ScenarioError, SpecError, locate
from flatland_ma.scenario.loader import file_text, list_streams, stream_dir
from flatland_ma.scenario.messages import problems_from
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.scenario.types import MAX_REWARD, Reward, Spec
from flatland_ma.scenario.yaml_reader import parse_yaml

Label = Annotated[str, Field(strict=True, pattern=r"^[a-z][a-z0-9_]*$", max_length=40)]
ScenarioName = Annotated[str, Field(strict=True, min_length=1, max_length=500)]
MAX_STEPS = 10**9
"""The longest a task may last, in agent-steps."""
MAX_TASKS = 256
"""The most tasks a stream may list."""
MAX_CYCLES = 1000
"""The most times a stream may go through its list of tasks."""


def _bounds(value: Any) -> tuple[float, float]:
    """``value_bounds`` as written: two finite numbers, each a reward a scenario file could
    give (so that their span, and every folded value, is a finite number)."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ValueError(f"expected [low, high], got {value!r}")
    for bound in value:
        if isinstance(bound, bool) or not isinstance(bound, (int, float)):
            hint = ""
            if isinstance(bound, str) and re.fullmatch(r"[-+]?[0-9]+[eE][-+]?[0-9]+", bound):
                hint = " (YAML reads a number with an exponent but no dot as text: write 1.0e+3)"
            raise ValueError(f"expected two numbers [low, high], got {bound!r}{hint}")
        if not (math.isfinite(bound) and abs(bound) <= MAX_REWARD):
            raise ValueError(
                f"{bound!r}: each bound must be finite and within ±{MAX_REWARD:g}, "
                "a reward a scenario could give"
            )
    return float(value[0]), float(value[1])


Bounds = Annotated[tuple[float, float], BeforeValidator(_bounds)]


class UntilSpec(Spec):
    """A curriculum stage's early end (``baselines.ppo --curriculum``): the stage ends once
    the learner's last ``episodes`` episodes in it average a return of at least
    ``mean_return``; its task's ``steps`` are then the most it lasts, and what it leaves
    unused goes to the stages after it."""

    mean_return: Reward
    """The mean of the learner's own (unshaped) episode returns that ends the stage."""
    episodes: Annotated[int, Field(strict=True, ge=1, le=100_000)] = 100
    """How many of the stage's latest episodes the mean is over (of every learning agent:
    an episode of four learning agents counts four)."""


class TaskSpec(Spec):
    """One task of a stream: a scenario (with overrides), how long it lasts, and for a
    multi-agent scenario which agents the learner drives and who drives the rest."""

    name: Label
    """The task's label, unique in the stream (tables and plots use it)."""
    scenario: ScenarioName
    """A shipped scenario's name or a scenario file's path."""
    overrides: dict[str, Any] = {}
    """Keyword overrides of the scenario, as ``load_scenario`` takes them."""
    steps: Annotated[int, Field(strict=True, ge=1, le=MAX_STEPS)]
    """How long the task lasts, in the learner's agent-steps."""
    focal: Annotated[tuple[Label, ...], Field(min_length=1, max_length=64)] | None = None
    """The agents the learner drives (agent names or team names); None: every agent."""
    background: Annotated[str, Field(strict=True, min_length=1, max_length=500)] | None = None
    """The shipped policy that drives every agent not focal."""
    until: UntilSpec | None = None
    """In a curriculum, end the stage early on the learner's returns (``UntilSpec``)."""

    @model_validator(mode="after")
    def _background_with_focal(self):
        if (self.focal is None) != (self.background is None):
            raise ValueError(
                "focal and background go together: who the learner drives, who the rest"
            )
        return self


class EvalSpec(Spec):
    """Evaluation blocks during a life, as the baselines run them."""

    every: Annotated[int, Field(strict=True, ge=1, le=MAX_STEPS)] = 15_000
    """Agent-steps between blocks."""
    episodes: Annotated[int, Field(strict=True, ge=1, le=100)] = 4
    """Episodes of every task in each block."""


class DriftSpec(Spec):
    """How the never-ending world changes, per step."""

    value_step: Annotated[float, Field(strict=True, ge=0, le=10, allow_inf_nan=False)] = 0.02
    """Standard deviation of each item group's reward's random walk, per step."""
    value_bounds: Bounds = (-1.0, 1.0)
    """The walk is reflected at these bounds (finite, each within the scenario format's
    largest reward, so that their span is a finite number)."""
    move: Annotated[float, Field(strict=True, ge=0, le=50, allow_inf_nan=False)] = 0.5
    """Standard deviation of each item's displacement per step, in world units (it stays
    where it is when the new place is not free)."""

    @model_validator(mode="after")
    def _ordered(self):
        low, high = self.value_bounds
        if not low < high:
            raise ValueError("value_bounds must be [low, high] with low < high")
        return self


class NeverEndingSpec(Spec):
    """One world, one episode that never ends, drifting."""

    scenario: ScenarioName
    overrides: dict[str, Any] = {}
    drift: DriftSpec = DriftSpec()


class StreamSpec(Spec):
    description: Annotated[str, Field(strict=True, max_length=1000)] = ""
    """What the stream tests."""
    announce: Annotated[bool, Field(strict=True)] = False
    """Tell the learner which task is on: the observation gains a ``task`` entry (one-hot)."""
    cycles: Annotated[int, Field(strict=True, ge=1, le=MAX_CYCLES)] = 1
    """The list of tasks, this many times over."""
    eval: EvalSpec = EvalSpec()
    tasks: Annotated[tuple[TaskSpec, ...], Field(min_length=1, max_length=MAX_TASKS)] | None = None
    """The tasks, in order."""
    never_ending: NeverEndingSpec | None = None
    """Instead of tasks: the never-ending mode."""

    @model_validator(mode="after")
    def _one_mode(self):
        if (self.tasks is None) == (self.never_ending is None):
            raise ValueError("a stream has either tasks or never_ending, not both, not neither")
        if self.tasks is not None:
            seen: dict[str, int] = {}
            for t, task in enumerate(self.tasks):
                if task.name in seen:
                    raise SpecError(
                        ("tasks", t, "name"), f"{task.name!r} names tasks[{seen[task.name]}] too"
                    )
                seen[task.name] = t
        return self


@dataclass
class Stream:
    """A loaded stream: its spec, and each task's checked scenario spec."""

    name: str
    spec: StreamSpec
    scenarios: list[ScenarioSpec]
    """Each task's scenario with its overrides (one, for the never-ending mode)."""
    source: str = ""
    _focal: list[list[int]] = field(default_factory=list)

    @property
    def task_labels(self) -> list[str]:
        if self.spec.tasks is None:
            return ["never_ending"]
        return [task.name for task in self.spec.tasks]

    @property
    def eval(self) -> EvalSpec:
        return self.spec.eval

    @property
    def never_ending(self) -> bool:
        return self.spec.never_ending is not None

    def task(self, index: int) -> TaskSpec:
        assert self.spec.tasks is not None, "the never-ending mode has no tasks"
        return self.spec.tasks[index]

    def focal(self, index: int) -> list[int]:
        """The indices of the agents the learner drives in task ``index``."""
        return self._focal[index]

    def segments(self) -> list[tuple[int, int, int]]:
        """The life, in order: (task index, first agent-step, end agent-step, exclusive),
        over every cycle; empty for the never-ending mode."""
        out, start = [], 0
        for _ in range(self.spec.cycles):
            for i, task in enumerate(self.spec.tasks or ()):
                out.append((i, start, start + task.steps))
                start += task.steps
        return out

    def scaled(self, factor: float) -> Stream:
        """The same stream with every task ``factor`` times as long (at least one step)."""
        if factor == 1 or self.spec.tasks is None:
            return self
        tasks = tuple(
            t.model_copy(update={"steps": max(1, round(t.steps * factor))}) for t in self.spec.tasks
        )
        spec = self.spec.model_copy(update={"tasks": tasks})
        return Stream(self.name, spec, self.scenarios, self.source, self._focal)

    @property
    def length(self) -> int | None:
        """Agent-steps in the whole life; None: never-ending."""
        segments = self.segments()
        return segments[-1][2] if segments else None


def load_stream(
    name: str | Path, padded: bool = False, every_slot: bool = False, curriculum: bool = False
) -> Stream:
    """A shipped stream by name, or a stream file; ``ScenarioError`` (file, line, key
    path) if it is not a valid stream, its scenarios and background policies included, or
    if the file is no regular file (``flatland_ma.scenario.files``). ``padded``: the
    learner reads its agents' observations padded to one space (``envs.padding``, as
    ``baselines.ppo`` does), so agents of a task may observe differently; the padded
    spaces must then agree from task to task. ``every_slot``: one network sits in every
    agent's slot of every task, whichever agents learn in it (a curriculum of
    ``baselines.ppo``), so the spaces and names checked are every agent's. ``curriculum``:
    the stream is a curriculum of ``baselines.ppo``, whose stages may end early (``until``);
    elsewhere a task with ``until`` is refused, since a life's tasks last their steps."""
    if isinstance(name, Stream):
        return name
    path = Path(name)
    if not path.suffix and not os.path.lexists(path):
        if str(name) not in list_streams():
            raise ValueError(f"no stream {str(name)!r}; streams: {', '.join(list_streams())}")
        path = stream_dir() / f"{name}.yaml"
    source = str(path)
    marks: Marks = {}
    raw = parse_yaml(file_text(path), source, marks)
    try:
        spec = StreamSpec.model_validate(raw)
    except ValidationError as err:
        raise ScenarioError(problems_from(err.errors(), StreamSpec, raw, marks, source)) from None
    _check_until(spec, curriculum, lambda key, message: locate(marks, key, message, source))
    return _checked(path.stem, spec, marks, source, padded, every_slot)


def _check_until(spec: StreamSpec, curriculum: bool, located) -> None:
    """``ScenarioError`` at a task's ``until`` outside a curriculum, or on the last task of
    a curriculum that goes through its tasks once (it runs to the run's end)."""
    tasks = spec.tasks or ()
    for t, task in enumerate(tasks):
        last = t == len(tasks) - 1 and spec.cycles == 1
        if task.until is not None and (not curriculum or last):
            message = (
                "the last task runs to the run's end: until has nothing to end early"
                if curriculum
                else "until ends a curriculum's stage early (baselines.ppo --curriculum); "
                "the tasks of a life last their steps"
            )
            raise ScenarioError([located(("tasks", t, "until"), message)])


def _checked(
    name: str, spec: StreamSpec, marks: Marks, source: str, padded: bool, every_slot: bool
) -> Stream:
    """Each task's scenario loaded and checked, faults located at the task's keys; every
    task's learner spaces equal; every background policy made for the agents it drives."""

    def fault(path: tuple, message: str) -> ScenarioError:
        return ScenarioError([locate(marks, path, message, source)])

    entries: list[tuple[tuple, Any]] = [
        (("tasks", t), task) for t, task in enumerate(spec.tasks or ())
    ]
    if spec.never_ending is not None:
        entries = [(("never_ending",), spec.never_ending)]
    scenarios, focal = [], []
    for key, task in entries:
        try:
            target = task_scenario_file(task.scenario, Path(source))
            scenario = scenario_of(target, task.overrides, Path(source))
            names = getattr(task, "focal", None)
            n = scenario.n_agents
            focal.append(
                list(range(n)) if names is None else focal_indices(scenario, names, task.scenario)
            )
        except SpecError as err:
            raise fault((*key, *err.path), str(err)) from None
        scenarios.append(scenario)
    stream = Stream(name, spec, scenarios, source, focal)
    slots = [list(range(s.n_agents)) for s in scenarios] if every_slot else focal
    _same_spaces(scenarios, slots, focal, entries, fault, padded)
    return stream


def task_scenario_file(name: str, stream_file: Path) -> Path | str:
    """The scenario a task names: the file beside the stream file when there is one by
    that name (as ``extends`` reads a scenario's base), else the name as given."""
    beside = stream_file.parent / name
    return beside if name and os.path.lexists(beside) else name


def _learner_spaces(env, focal: list[int], padded: bool) -> set[tuple[str, str]]:
    """The observation and action spaces of ``env``'s agents ``focal``, as text; with
    ``padded``, agents that observe differently observe their padded space (``SpecError``
    where they cannot share one)."""
    from flatland_ma.envs.padding import Padding

    agents = [env.possible_agents[i] for i in focal]
    observed = [env.observation_space(agent) for agent in agents]
    if padded and len({str(space) for space in observed}) > 1:
        try:
            observed = [Padding(observed).space] * len(agents)
        except ValueError as err:
            message = f"the learner's agents cannot share one padded space: {err}"
            raise SpecError((), message) from None
    return {(str(o), str(env.action_space(a))) for o, a in zip(observed, agents)}


def _same_spaces(
    scenarios: list[ScenarioSpec],
    slots: list[list[int]],
    focals: list[list[int]],
    entries,
    fault,
    padded: bool,
) -> None:
    """Whether the network's agents (``slots``, per task: the learner's, or every one)
    observe and act alike in every task (``padded``: through the padded space of each
    task's agents), under the same names, and each background policy can drive the agents
    not ``focals``; raises ``fault`` at the task's key where not."""
    from flatland_ma.envs.parallel import FlatlandParallelEnv

    first = None
    for (key, task), scenario, slot, focal in zip(entries, scenarios, slots, focals):
        env = FlatlandParallelEnv(scenario)
        names = [env.possible_agents[i] for i in slot]
        try:
            spaces = _learner_spaces(env, slot, padded)
            background = getattr(task, "background", None)
            if background is not None:
                others = [a for i, a in enumerate(env.possible_agents) if i not in focal]
                check_policy(background, env, others, ("background",))
        except SpecError as err:
            raise fault((*key, *err.path), str(err)) from None
        finally:
            env.close()
        if len(spaces) > 1:
            raise fault(key, f"the learner's agents have different spaces here: {sorted(spaces)}")
        (space,) = spaces
        if first is None:
            first = (key, space, names)
        elif names != first[2]:
            raise fault(
                key,
                f"the learner drives {names} here, but {first[2]} in the first task: "
                "one policy lives the whole life, under the same agent names",
            )
        elif space != first[1]:
            raise fault(
                key,
                f"the learner observes {space[0]} and acts in {space[1]} here, but "
                f"{first[1][0]} and {first[1][1]} in the first task: one policy lives "
                "the whole life",
            )
