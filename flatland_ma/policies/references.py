"""What the tasks of stream and suite files refer to, resolved when the file loads: a
scenario (with keyword overrides), the agents a policy drives (focal slots), and policies
by name (a shipped one, or a checkpoint file).

Each function raises ``SpecError`` with a key path relative to the task's entry (e.g.
``("scenario",)``, ``("overrides", "items", 0, "color")``, ``("background", 1)``); the
file's loader prefixes the task's own path and locates it (file, line), as it does any
fault of the file.
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from flatland_ma.scenario.errors import KeyPath, ScenarioError, SpecError
from flatland_ma.scenario.files import check_regular_file
from flatland_ma.scenario.overrides import OVERRIDES
from flatland_ma.scenario.schema import ScenarioSpec


def scenario_of(name: str | Path, overrides: Mapping, file: Path | None = None) -> ScenarioSpec:
    """The scenario ``name`` with ``overrides``, loaded and checked as the envs will build
    it. A fault of the scenario itself (no such scenario, a file that does not load, an
    ``extends`` cycle, the referring ``file`` itself) is at ``scenario``; one that comes
    from the overrides at the override's own key under ``overrides``."""
    from flatland_ma.build.feasibility import check_scenario
    from flatland_ma.scenario.loader import load_scenario

    if file is not None and Path(name).is_file() and Path(name).resolve() == file.resolve():
        raise SpecError(("scenario",), f"{name}: the file that names it, not a scenario")
    try:
        scenario = load_scenario(name, **overrides)
        check_scenario(scenario)
    except ScenarioError as err:
        mine = [p for p in err.problems if p.source == OVERRIDES]
        if mine:
            raise SpecError(("overrides", *mine[0].path), mine[0].message) from None
        first = str(err.problems[0]) if err.problems else str(err)
        raise SpecError(("scenario",), f"{name}: {first}") from None
    except (ValueError, TypeError) as err:
        first = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise SpecError(("scenario",), f"{name}: {first}") from None
    return scenario


def focal_indices(scenario: ScenarioSpec, names: Sequence[str], what: str) -> list[int]:
    """The indices of the agents ``names`` (agent names, ``agent_<i>`` or by team as
    ``<team>_<k>``, or team names) stand for, sorted; ``SpecError`` at ``focal[k]`` for a
    name that is neither, at ``focal`` when they cover every agent (``what`` names the
    scenario in messages)."""
    agents = list(scenario.agent_names)
    firsts, first = {}, 0
    for team in scenario.teams:
        firsts[team.name] = range(first, first + team.size)
        first += team.size
    out: set[int] = set()
    for k, name in enumerate(names):
        if name in agents:
            out.add(agents.index(name))
        elif name in firsts:
            out.update(firsts[name])
        else:
            teams = f"; teams: {', '.join(firsts)}" if firsts else ""
            raise SpecError(
                ("focal", k),
                f"{name!r} is no agent or team of {what}; agents: {', '.join(agents)}{teams}",
            )
    if len(out) == scenario.n_agents:
        raise SpecError(("focal",), "every agent is focal: leave background slots for partners")
    return sorted(out)


def check_policy_name(name: str, path: KeyPath) -> None:
    """``SpecError`` at ``path`` unless ``name`` is a shipped policy or names a regular
    file (a checkpoint; its contents are the checkpoint reader's to check)."""
    from flatland_ma.policies.named import SHIPPED

    if name in SHIPPED:
        return
    if not os.path.lexists(name):
        if Path(name).suffix or "/" in name or os.sep in name:
            raise SpecError(path, f"checkpoint {name}: no such file")
        hint = difflib.get_close_matches(name, list(SHIPPED), n=1)
        maybe = f" (did you mean {hint[0]!r}?)" if hint else ""
        raise SpecError(
            path, f"no policy {name!r}{maybe}: one of {', '.join(SHIPPED)}, or a checkpoint file"
        )
    try:
        check_regular_file(name)
    except ScenarioError as err:
        raise SpecError(path, f"checkpoint {name}: {err.problems[0].message}") from None


def check_policy(name: str, env, agents: Sequence[str], path: KeyPath) -> None:
    """``name`` made for each of ``agents`` of ``env``, as the runners make it: a name that
    is no policy, or a policy that cannot drive one of them, is a ``SpecError`` at
    ``path``."""
    from flatland_ma.policies.named import make_policy

    check_policy_name(name, path)
    for agent in agents:
        try:
            make_policy(name, env, agent, seed=0)
        except ValueError as err:
            raise SpecError(path, f"{name} cannot drive {agent}: {err}") from None
