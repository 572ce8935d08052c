"""Sensors, rules, parts and generators from your own package, without editing this one.

A kind is two classes: its implementation, a subclass of one of the four bases, and its
spec, a pydantic model subclassing the matching spec base with the tag that files write
(a ``Literal`` of the kind's name) and its keys:

- a sensor: ``sensors.sensor.Sensor``, spec ``scenario.spec_sensors.SensorBaseSpec``, tag
  ``type``, listed under an agent's ``sensors``;
- a rule: ``tasks.rule.Rule``, spec ``scenario.spec_rules.RuleBaseSpec``, tag ``rule``,
  listed under ``rules``;
- a part: ``agents.parts.Part`` (``Jointed`` for a body on a joint), spec
  ``scenario.spec_agent.PartBaseSpec``, tag ``type``, listed under an agent's ``parts``;
- a generator: ``build.generators.Generator``, spec
  ``scenario.spec_world.GeneratorBaseSpec``, tag ``generator``, listed under
  ``layout.generators``.

``register(spec, implementation)`` joins them; from then on scenario files name the kind,
the loader validates their entries with the spec (errors name the file, line and key
path), and the JSON schema written in this process (``flatland_ma.scenario.json_schema``)
includes the spec.

Registering from an entry point, so that every process that loads a file finds the kinds
without importing your package first: in your ``pyproject.toml``

    [project.entry-points."flatland_ma.extensions"]
    compass = "my_package.flatland:register"

where ``register`` is a function of no argument that calls ``flatland_ma.register`` (or
name a module that calls it when imported). Entry points are loaded the first time a
file names a kind that is not known yet, or when every kind is listed (the JSON schema).
"""

from __future__ import annotations

from pydantic import BaseModel

from flatland_ma.kinds.entry_points import load_extensions
from flatland_ma.scenario.kinds import SpecKinds, tag_of
from flatland_ma.scenario.spec_agent import PARTS
from flatland_ma.scenario.spec_rules import RULES
from flatland_ma.scenario.spec_sensors import SENSORS
from flatland_ma.scenario.spec_world import GENERATORS

SPEC_FAMILIES: dict[str, SpecKinds] = {
    "sensor": SENSORS,
    "rule": RULES,
    "part": PARTS,
    "generator": GENERATORS,
}
"""The spec registry of each family, by the name its implementation registry gives it."""


def register(spec: type[BaseModel], implementation: type) -> str:
    """Make the kind that ``implementation`` is (a subclass of ``Sensor``, ``Rule``,
    ``Part`` or ``Generator``) and ``spec`` describes known to scenario files; return its
    name (the spec's tag). The implementation's ``kind`` is the tag: a class statement may
    name it (``kind="compass"``) or leave it to this call. A name another class has
    already is an error; registering the same pair again does nothing."""
    kinds = getattr(implementation, "KINDS", None)
    family = SPEC_FAMILIES.get(getattr(kinds, "what", ""))
    if kinds is None or family is None:
        raise TypeError(
            f"{implementation!r} is no sensor, rule, part or generator: subclass "
            "flatland_ma.sensors.sensor.Sensor, flatland_ma.tasks.rule.Rule, "
            "flatland_ma.agents.parts.Part or flatland_ma.build.generators.Generator"
        )
    name = tag_of(spec, family.tag) if isinstance(spec, type) else None
    if name is None or not issubclass(spec, family.base):
        raise TypeError(
            f"a {family.what}'s spec is a subclass of {family.base.__name__} with a field "
            f"{family.tag}: Literal['<name>']; got {spec!r}"
        )
    own = implementation.__dict__.get("kind")
    if own is not None and own != name:
        raise ValueError(
            f"{implementation.__name__} is kind {own!r} but its spec {spec.__name__} is "
            f"{family.tag} {name!r}: give them one name"
        )
    kinds.discover()  # the shipped kinds first: a name of theirs is taken
    taken = dict.get(kinds, name)
    if taken is not None and taken is not implementation:
        raise ValueError(
            f"a {family.what} of kind {name!r} exists already ({taken.__module__}."
            f"{taken.__qualname__}); choose another name"
        )
    family.add(spec)
    implementation.kind = name
    kinds[name] = implementation
    return name


__all__ = ["SPEC_FAMILIES", "load_extensions", "register"]
