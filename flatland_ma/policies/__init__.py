"""Policies that ship with the package: a scripted greedy forager, a sniffer that
follows its nose and a wall follower for mazes (each from its own observation only), a
search-based planner and a scripted carrier of objects (privileged: they read the
world), and uniform random play."""

from flatland_ma.policies.carrier import CarrierPolicy
from flatland_ma.policies.greedy import GreedyForager
from flatland_ma.policies.idle import IdlePolicy
from flatland_ma.policies.named import SHIPPED, Policy, make_policy
from flatland_ma.policies.planner import PlannerPolicy
from flatland_ma.policies.rollout import RandomPolicy, evaluate
from flatland_ma.policies.signals import Follower, Heeder, Signaller
from flatland_ma.policies.sniffer import Sniffer
from flatland_ma.policies.wall_follower import WallFollower

__all__ = [
    "CarrierPolicy",
    "Follower",
    "GreedyForager",
    "Heeder",
    "IdlePolicy",
    "PlannerPolicy",
    "Policy",
    "RandomPolicy",
    "SHIPPED",
    "Signaller",
    "Sniffer",
    "WallFollower",
    "evaluate",
    "make_policy",
]
