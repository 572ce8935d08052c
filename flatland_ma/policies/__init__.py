"""Policies that ship with the package: a scripted greedy forager (from its observation
only), a search-based planner and a scripted carrier of objects (privileged: they read
the world), and uniform random play."""

from flatland_ma.policies.carrier import CarrierPolicy
from flatland_ma.policies.greedy import GreedyForager
from flatland_ma.policies.planner import PlannerPolicy
from flatland_ma.policies.rollout import RandomPolicy, evaluate

__all__ = ["CarrierPolicy", "GreedyForager", "PlannerPolicy", "RandomPolicy", "evaluate"]
