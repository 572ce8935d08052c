"""The scenario an env is made of: a shipped scenario's name, a file or a spec, with
keyword overrides and PettingZoo's ``max_cycles`` merged in, loaded, validated and checked
to build, before any world exists."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from flatland_ma.build.feasibility import check_scenario
from flatland_ma.render.display import missing_display, no_window
from flatland_ma.scenario.loader import load_scenario
from flatland_ma.scenario.schema import ScenarioSpec


def checked_spec(
    scenario: str | Path | ScenarioSpec, max_cycles: int | None, overrides: dict
) -> ScenarioSpec:
    """The scenario (a shipped name, a file or a spec) with ``overrides`` and the episode
    length ``max_cycles`` merged in, checked to build (``check_scenario``)."""
    if max_cycles is not None:
        overrides = with_episode_length(overrides, max_cycles)
    if isinstance(scenario, ScenarioSpec):
        if overrides:
            raise TypeError("overrides apply to scenario names or files, not to a spec")
        spec = scenario
    else:
        spec = load_scenario(scenario, **overrides)
    check_scenario(spec)
    return spec


def with_episode_length(overrides: dict, max_cycles: int) -> dict:
    """``overrides`` with ``episode.max_steps`` set to ``max_cycles`` (PettingZoo's name)."""
    episode = overrides.get("episode", {})
    if not isinstance(episode, Mapping):
        return overrides  # validation reports the bad ``episode``
    if "max_steps" in episode:
        raise TypeError("max_cycles and episode.max_steps both set the episode length; give one")
    return {**overrides, "episode": {**episode, "max_steps": max_cycles}}


def no_window_without_display(render_mode: str | None) -> None:
    """Refuse ``render_mode="human"`` where no window can open."""
    if render_mode == "human":
        no_window(missing_display())
