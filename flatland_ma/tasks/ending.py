"""How episodes end for everyone: when one agent's ends (``shared_end``), or once no item
of a group is left (``end_when_eaten``). Runs last, after every other rule."""

from __future__ import annotations

from flatland_ma.tasks.items import ItemRule
from flatland_ma.tasks.rule import Rule, Step


class EndingRule(Rule):
    def __init__(self, items: ItemRule, shared_end: bool = False, end_when_eaten=None):
        self.items = items
        self.shared_end = shared_end
        self.end_when_eaten = end_when_eaten

    def apply(self, step: Step) -> None:
        if (self.shared_end and any(step.terminated)) or (
            self.end_when_eaten is not None and self.items.none_left(self.end_when_eaten)
        ):
            step.end_all = True
