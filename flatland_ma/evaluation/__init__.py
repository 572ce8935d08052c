"""Evaluation of a policy against held-out partners and opponents: suites of tasks
(``scenarios/suites/``), the runner behind ``flatland-ma evaluate``, and the statistics
(normalised scores, interquartile mean, stratified bootstrap intervals, Elo), which need
SciPy (the ``train`` extra): they are imported when first used."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from flatland_ma.evaluation.runner import crossplay, run_suite
    from flatland_ma.evaluation.stats import elo, iqm, normalise, stratified_bootstrap
    from flatland_ma.evaluation.suite import SuiteSpec, list_suites, load_suite

_EXPORTS = {
    "elo": "stats",
    "iqm": "stats",
    "normalise": "stats",
    "stratified_bootstrap": "stats",
    "SuiteSpec": "suite",
    "list_suites": "suite",
    "load_suite": "suite",
    "run_suite": "runner",
    "crossplay": "runner",
}

__all__ = [
    "SuiteSpec",
    "crossplay",
    "elo",
    "iqm",
    "list_suites",
    "load_suite",
    "normalise",
    "run_suite",
    "stratified_bootstrap",
]


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
