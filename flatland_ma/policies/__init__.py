"""Policies that ship with the package: a scripted greedy forager and uniform random play."""

from flatland_ma.policies.greedy import GreedyForager
from flatland_ma.policies.rollout import RandomPolicy, evaluate

__all__ = ["GreedyForager", "RandomPolicy", "evaluate"]
