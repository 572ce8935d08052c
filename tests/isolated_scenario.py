"""The child's side of a scenario case (``tests/isolated.py`` forks it): load the scenario
with ``flatland_ma.parallel_env``; if it loads, reset it with two seeds and step it with
random actions, checking that every observation is finite and inside its space."""

from __future__ import annotations

import time
import traceback
import warnings

SEEDS = (0, 1)
TEXT_KEPT = 4000
"""Longest message or traceback an outcome keeps."""


def run_case(request: dict) -> dict:
    """Load the case's scenario and, if it loads, reset and step it; the report's fields
    are ``Outcome``'s."""
    import numpy as np

    import flatland_ma
    from flatland_ma.scenario.errors import ScenarioError, format_path

    report: dict = {"kind": "works"}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        started = time.perf_counter()
        try:
            env = flatland_ma.parallel_env(request["scenario"], **request["overrides"])
        except ScenarioError as err:
            report = _scenario_error_report(err, format_path)
        except BaseException as err:  # noqa: BLE001
            report = exception_report(_kind_of(err), err, phase="load")
        else:
            report["load_s"] = time.perf_counter() - started
            try:
                _exercise(env, request["steps"], report, np)
            except BaseException as err:  # noqa: BLE001
                report = {**report, **exception_report(_kind_of(err), err, report["phase"])}
    report["warnings"] = sorted({f"{w.category.__name__}: {w.message}" for w in caught or []})[:20]
    return report


def _exercise(env, steps: int, report: dict, np) -> None:
    """Reset with each seed and step at random, checking every observation."""
    report.update(steps=0, finite=True, in_space=True, bad_observation="")
    report.update(rewards_finite=True, rewards_nan=False, bad_reward="")
    for seed in SEEDS:
        report["phase"] = "reset"
        started = time.perf_counter()
        observations, _ = env.reset(seed=seed)
        report.setdefault("reset_s", time.perf_counter() - started)
        _check(env, observations, {}, report, np)
        for i, agent in enumerate(env.possible_agents):
            env.action_space(agent).seed(seed * 1000 + i)
        report["phase"] = "step"
        for _ in range(steps):
            if not env.agents:
                break
            actions = {a: env.action_space(a).sample() for a in env.agents}
            observations, rewards, *_ = env.step(actions)
            report["steps"] += 1
            _check(env, observations, rewards, report, np)
    report["phase"] = ""


def _check(env, observations: dict, rewards: dict, report: dict, np) -> None:
    for agent, observation in observations.items():
        arrays = observation.values() if isinstance(observation, dict) else [observation]
        if not all(np.isfinite(a).all() for a in arrays):
            report["finite"] = False
            report["bad_observation"] = report["bad_observation"] or (
                f"{agent}'s observation after {report['steps']} steps is not finite"
            )
        if not env.observation_space(agent).contains(observation):
            report["in_space"] = False
            report["bad_observation"] = report["bad_observation"] or (
                f"{agent}'s observation after {report['steps']} steps is outside its space"
            )
    for agent, reward in rewards.items():
        if not np.isfinite(reward):
            report["rewards_finite"] = False
            report["rewards_nan"] = report["rewards_nan"] or bool(np.isnan(reward))
            report["bad_reward"] = report["bad_reward"] or (
                f"{agent}'s reward after {report['steps']} steps is {reward}"
            )


def _scenario_error_report(err, format_path) -> dict:
    problems = [
        {
            "source": p.source,
            "line": p.line,
            "key": format_path(p.path),
            "message": p.message[:TEXT_KEPT],
        }
        for p in err.problems
    ][:50]
    if not problems:
        kind = "unlocated"
    elif any("internal error" in p["message"] for p in problems):
        kind = "internal-error"
    elif all(p["source"] for p in problems):
        kind = "located"
    else:
        kind = "unlocated"
    report = {"kind": kind, "problems": problems, "phase": "load"}
    report["detail"] = str(err.problems[0])[:TEXT_KEPT] if err.problems else str(err)
    if kind == "internal-error":
        report["traceback"] = _traceback(err.__cause__ or err)
    return report


def _kind_of(err: BaseException) -> str:
    return "memory" if isinstance(err, MemoryError) else "other-exception"


def exception_report(kind: str, err: BaseException, phase: str = "") -> dict:
    return {
        "kind": kind,
        "phase": phase,
        "detail": f"{type(err).__name__}: {err}"[:TEXT_KEPT],
        "traceback": _traceback(err),
    }


def _traceback(err: BaseException) -> str:
    text = "".join(traceback.format_exception(type(err), err, err.__traceback__))
    return text[-TEXT_KEPT:]
