"""Graspers: a closed hand that touches a graspable object holds it with a pivot joint.

A grasper is a part (one control: > 0 closes the hand, otherwise it opens) at the tip of
an arm segment. The hold transmits at most the grasper's ``strength``; pulled harder (an
object too heavy to drag, another agent tugging), the object slips, and once it has
slipped farther than ``break_distance`` the hold breaks and the hand opens. It cannot
close on anything again for ``REGRASP_STEPS`` steps.
"""

from __future__ import annotations

import pymunk

from flatland_ma.agents.body import AgentBody
from flatland_ma.agents.parts import ArmSegment, Control, Link, Part, agent_filter
from flatland_ma.world.entities import CollisionType, Entity

REGRASP_STEPS = 15
"""Steps after a hold breaks during which the hand cannot grasp."""
HOLD_BIAS = 300.0
"""Fastest speed (units per second) at which a hold pulls a slipped object back."""


class Grasper(Part, kind="grasper"):
    """A disc of ``radius`` at the tip of ``segment`` that holds what it touches when
    closed (see the module docstring). ``grip`` names its continuous entry, ``prefix``
    starts the names of its ``grasp`` and ``release`` macros."""

    holds = True

    def __init__(
        self,
        grip: str,
        prefix: str,
        label: str,
        segment: ArmSegment,
        radius: float = 3.0,
        strength: float = 4_000.0,
        break_distance: float = 6.0,
    ):
        self.segment_part = segment
        self.radius, self.strength, self.break_distance = radius, strength, break_distance
        self.controls = (Control(grip, f"{prefix}grasp", f"{prefix}release"),)
        self.label = label
        self.shape: pymunk.Circle  # made by ``build``
        self.segment: Link
        """The arm segment's link whose tip it is (set by ``build``)."""
        self.closed = False
        self.touching: list[Entity] = []
        """Graspable objects the hand touches now, first touched first (the world keeps
        it up to date)."""
        self.joint: pymunk.PivotJoint | None = None
        self.held: Entity | None = None
        self.cooldown = 0

    def build(self, agent: AgentBody) -> None:
        tip = self.segment_part.link
        grip = pymunk.Circle(tip.body, self.radius, (self.segment_part.length, 0.0))
        grip.collision_type = CollisionType.GRASPER
        grip.filter = agent_filter(agent.owner)
        grip.friction = 1.0
        tip.shapes = (*tip.shapes, grip)
        self.shape, self.segment = grip, tip
        agent.hands.append(self)
        return None

    def command(self, values, angles: dict) -> None:
        (value,) = values
        if value is not None:
            self.closed = value > 0.0

    def reach(self) -> float:
        return self.segment_part.reach() + self.radius

    def top_speed(self, base_speed: float, base_turn: float) -> float:
        return self.segment_part.top_speed(base_speed, base_turn)

    def half_width(self) -> float:
        return self.radius

    def own_shapes(self) -> tuple[pymunk.Shape, ...]:
        return (self.shape,)

    def slip(self) -> float:
        """How far the held object has slipped from where it was grasped."""
        assert self.joint is not None and self.held is not None, "it holds nothing"
        a = self.segment.body.local_to_world(self.joint.anchor_a)
        b = self.held.body.local_to_world(self.joint.anchor_b)
        return (a - b).length


class Hands:
    """All the graspers of one world; ``update`` runs after each physics step."""

    def __init__(self, space: pymunk.Space, hands: list[Grasper]):
        self.space = space
        self.hands = hands

    def update(self) -> None:
        for hand in self.hands:
            if hand.held is not None:
                if not hand.closed:
                    self.let_go(hand)
                elif hand.slip() > hand.break_distance:
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

    def _hold(self, hand: Grasper, thing) -> None:
        anchor = hand.shape.offset
        point = hand.segment.body.local_to_world(anchor)
        joint = pymunk.PivotJoint(
            hand.segment.body, thing.body, anchor, thing.body.world_to_local(point)
        )
        joint.max_force = hand.strength
        joint.max_bias = HOLD_BIAS
        self.space.add(joint)
        hand.joint, hand.held = joint, thing

    def let_go(self, hand: Grasper) -> None:
        if hand.joint is not None:
            self.space.remove(hand.joint)
        hand.joint, hand.held = None, None

    def drop(self, thing) -> None:
        """Every hand holding ``thing`` lets go (it was delivered or taken away)."""
        for hand in self.hands:
            if hand.held is thing:
                self.let_go(hand)

    def drop_all_of(self, hands: list[Grasper]) -> None:
        for hand in hands:
            self.let_go(hand)
            hand.closed = False
