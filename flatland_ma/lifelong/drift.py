"""The never-ending world's drift: item values on a random walk, items wandering.

After every step, each item group's reward takes a Gaussian step of ``value_step`` and is
reflected into ``value_bounds``; each item still out moves by a Gaussian displacement of
``move`` world units per axis, unless its new place is not free (it then stays). Both draw
from the env's one generator, so the same seed and actions give the same drift.
"""

from __future__ import annotations

import numpy as np

from flatland_ma.lifelong.streams import DriftSpec
from flatland_ma.tasks.items import ItemRule
from flatland_ma.world.entities import Item


def reflect(values: np.ndarray, low: float, high: float) -> np.ndarray:
    """``values`` folded back into [low, high] (as a walk reflected at both bounds)."""
    span = high - low
    folded = np.mod(values - low, 2 * span)
    return low + np.where(folded > span, 2 * span - folded, folded)


def item_rule(env) -> ItemRule:
    """The items' rule of ``env``'s running episode (where the groups' values live)."""
    return next(rule for rule in env.running.task.rules if isinstance(rule, ItemRule))


class Drift:
    def __init__(self, spec: DriftSpec):
        self.spec = spec

    def apply(self, env) -> None:
        """One step of drift of ``env``'s running world, drawn from ``env.np_random``."""
        rng: np.random.Generator = env.np_random
        spec = self.spec
        rule = item_rule(env)
        if spec.value_step > 0 and len(rule.values):
            walked = rule.values + rng.normal(0.0, spec.value_step, len(rule.values))
            rule.values[:] = reflect(walked, *spec.value_bounds)
        if spec.move > 0:
            world = env.running.world
            items = [item for item in world.of_type(Item) if item.visible]
            steps = rng.normal(0.0, spec.move, (len(items), 2))
            for item, (dx, dy) in zip(items, steps):
                x, y = item.body.position
                if world.is_free(x + dx, y + dy, item.group.radius, ignore=item):
                    world.move_static(item, x + dx, y + dy)
