"""The checks that need a scenario's layout or its agents' parts, beyond what the file
format checks alone: agents with their parts fit in the arena, no part moves fast enough
to cross a wall in one physics substep, and the scenario builds with room to spare at
several seeds (placement, reachability, overlaps). The envs and ``flatland-ma validate``
run them; each fault is located in the file like any other.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from flatland_ma.build.bodies import fastest_parts, footprint, make_parts, make_sensors
from flatland_ma.build.builder import lay_ground, populate
from flatland_ma.build.capacity import check_capacity
from flatland_ma.build.kind_faults import fault_in_extension
from flatland_ma.kinds.registry import ExtensionError
from flatland_ma.scenario.checks import wall_thicknesses
from flatland_ma.scenario.errors import Problem, ScenarioError, SpecError
from flatland_ma.scenario.loader import load_scenario
from flatland_ma.scenario.schema import ScenarioSpec

CHECK_SEEDS = 4
"""How many seeds ``check_layout`` builds a scenario with."""
PASSED_KEPT = 256
"""How many passed scenarios a process remembers (each is checked once)."""
_passed: dict[tuple[str, str], None] = {}
"""The scenarios that passed, by source and contents: a spec is frozen and the checks
read nothing else, so an env made again from the same file is not checked again."""


def check_scenario(scenario: str | Path | ScenarioSpec, **overrides: Any) -> ScenarioSpec:
    """Load a scenario (by name, path or spec) and run every check on it; raise
    ``ScenarioError`` naming the file, line and key of each fault found."""
    spec = scenario if isinstance(scenario, ScenarioSpec) else load_scenario(scenario, **overrides)
    key = (spec.source, spec.model_dump_json())
    if key in _passed:
        return spec
    try:
        check_parts(spec)
        check_layout(spec)
    except SpecError as err:
        raise spec.locate(err) from None
    except (ScenarioError, ExtensionError):
        raise
    except Exception as err:
        where = fault_in_extension(err)
        if where is not None:  # a user's kind: its code's fault, not the file's or ours
            raise ExtensionError(
                f"an extension's code failed while checking {spec.source}: "
                f"{type(err).__name__}: {err}, raised in {where}"
            ) from err
        source = spec.source
        message = f"internal error while checking ({type(err).__name__}: {err}); please report it"
        raise ScenarioError([Problem(source, None, (), message)]) from err
    _passed[key] = None
    while len(_passed) > PASSED_KEPT:
        del _passed[next(iter(_passed))]
    return spec


def check_parts(spec: ScenarioSpec) -> None:
    """Agents with their parts fit in the arena; no part can cross a wall in a substep."""
    for body_path, agent, _ in spec.agent_kinds():
        _check_body(spec, body_path, agent)


def _check_body(spec: ScenarioSpec, body_path, agent) -> None:
    parts = make_parts(agent)
    width, height = spec.arena.size
    reach = footprint(agent, parts)
    if 2 * reach >= min(width, height):
        path = body_path + (("arms",) if agent.arms else ("head",))
        raise SpecError(
            path,
            f"agents reaching {reach:g} from their centre (with their parts) do not fit in "
            f"the {width:g} x {height:g} arena",
        )
    # Between two contact checks a body moves one substep's travel: a part that can
    # travel farther than the wall's half thickness plus its own could pass through.
    substep = spec.physics.dt / spec.physics.substeps
    for path, thickness in wall_thicknesses(spec):
        for part, speed, half in fastest_parts(agent, parts):
            travel = speed * substep
            if thickness / 2 + half <= travel:
                raise SpecError(
                    path,
                    f"walls {thickness:g} thick can be crossed by an agent's {part}, which "
                    f"can move {travel:.3g} units per substep; use thicker walls, more "
                    "physics substeps, or slower motors",
                )


def check_layout(spec: ScenarioSpec) -> None:
    """Build with a few fixed seeds, checking there is room to spare for what is placed at
    random: raise ``SpecError`` if the scenario cannot be built reliably."""
    sensors = [make_sensors(agent, spec.channel, spec.n_agents) for agent in spec.agent_specs]
    for seed in range(CHECK_SEEDS):
        rng = np.random.default_rng(seed)
        site = lay_ground(spec, rng)
        check_capacity(spec, site.placer)
        populate(spec, site, rng, sensors)
