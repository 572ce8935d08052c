"""Graspers: a closed hand that touches a graspable object holds it with a pivot joint.

The hold transmits at most the grasper's ``strength``; pulled harder (an object too heavy
to drag, another agent tugging), the object slips, and once it has slipped farther than
``break_distance`` the hold breaks and the hand opens. It cannot close on anything again
for ``REGRASP_STEPS`` steps.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pymunk

from flatland_ma.scenario.schema import GrasperSpec

REGRASP_STEPS = 15
"""Steps after a hold breaks during which the hand cannot grasp."""
HOLD_BIAS = 300.0
"""Fastest speed (units per second) at which a hold pulls a slipped object back."""


@dataclass(eq=False)
class Hand:
    spec: GrasperSpec
    shape: pymunk.Circle
    segment: object
    """The arm segment (``parts.Part``) whose tip it is."""
    closed: bool = False
    touching: list = field(default_factory=list)
    """Graspable objects the hand touches now, first touched first."""
    joint: pymunk.PivotJoint | None = None
    held: object = None
    cooldown: int = 0

    def slip(self) -> float:
        """How far the held object has slipped from where it was grasped."""
        a = self.segment.body.local_to_world(self.joint.anchor_a)
        b = self.held.body.local_to_world(self.joint.anchor_b)
        return (a - b).length


class Hands:
    """All the graspers of one world; ``update`` runs after each physics step."""

    def __init__(self, space: pymunk.Space, hands: list[Hand]):
        self.space = space
        self.hands = hands

    def update(self) -> None:
        for hand in self.hands:
            if hand.held is not None:
                if not hand.closed:
                    self.let_go(hand)
                elif hand.slip() > hand.spec.break_distance:
                    self.let_go(hand)
                    hand.closed = False
                    hand.cooldown = REGRASP_STEPS
            if hand.cooldown:
                hand.cooldown -= 1
            elif hand.closed and hand.held is None:
                for thing in hand.touching:
                    if thing.visible:
                        self._hold(hand, thing)
                        break

    def _hold(self, hand: Hand, thing) -> None:
        anchor = hand.shape.offset
        point = hand.segment.body.local_to_world(anchor)
        joint = pymunk.PivotJoint(
            hand.segment.body, thing.body, anchor, thing.body.world_to_local(point)
        )
        joint.max_force = hand.spec.strength
        joint.max_bias = HOLD_BIAS
        self.space.add(joint)
        hand.joint, hand.held = joint, thing

    def let_go(self, hand: Hand) -> None:
        if hand.joint is not None:
            self.space.remove(hand.joint)
        hand.joint, hand.held = None, None

    def drop(self, thing) -> None:
        """Every hand holding ``thing`` lets go (it was delivered or taken away)."""
        for hand in self.hands:
            if hand.held is thing:
                self.let_go(hand)

    def drop_all_of(self, hands: list[Hand]) -> None:
        for hand in hands:
            self.let_go(hand)
            hand.closed = False
