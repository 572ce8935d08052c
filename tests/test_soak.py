"""The soak run (tests/soak.py): a million agent-steps and 500 env creations leave memory
flat after warm-up and every observation finite and in its space (make test-slow, or
make soak for the report); a small run checks the report on every default run."""

import math

import numpy as np
import pytest

import flatland_ma
from tests.soak import MAX_GROWTH, ObservationCheck, failures, format_report, run_soak


def test_the_observation_check_finds_non_finite_and_out_of_space_observations():
    env = flatland_ma.parallel_env("fruits_poisons_multi")
    observations, _ = env.reset(seed=0)
    check = ObservationCheck(env)
    check(observations, "good")
    check(observations, "good, with contains", contains=True)
    assert check.bad == 0 and check.checked == 8
    for bad in (np.nan, np.inf, -0.5, 1.5):
        broken = {a: o.copy() for a, o in observations.items()}
        broken["agent_2"][3, 1] = bad
        check(broken, f"value {bad}")
    wrong = dict(observations, agent_1=observations["agent_1"].astype(np.float64))
    check(wrong, "dtype")
    assert check.bad == 5
    assert check.examples[0] == "value nan, agent_2: 1 non-finite values"
    assert check.examples[2].startswith("value -0.5, agent_2: not in Box(")
    assert check.examples[4].startswith("dtype, agent_1: not in Box(")
    env.close()


def test_a_small_soak_reports_both_phases_and_finds_no_bad_observation():
    # 4,000 agent-steps and 10 creations (about a second). Memory growth is not asserted
    # here: a leak small enough to matter (say 100 bytes an agent-step) adds 0.4 MB over
    # this run, under the few MB that the first episodes and creations allocate once (the
    # allocator's arenas, caches, free lists) on a process of over 150 MB whose size also
    # depends on the tests run before in it; only the full run can tell a leak.
    report = run_soak(4_000, 10, window=1_000, warmup=0.25, creation_warmup=0.2)
    steps, made, observations = report["steps"], report["creations"], report["observations"]
    assert steps["scenario"] == "fruits_poisons_multi" and steps["agents"] == 4
    assert steps["agent_steps"] == 4_000 and steps["env_steps"] == 1_000
    assert steps["episodes"] == 2  # episodes of 500 steps, a reset between them
    assert steps["warmup_agent_steps"] == 1_000
    assert [w["agent_steps"] for w in steps["windows"]] == [1_000, 2_000, 3_000, 4_000]
    for key in ("rss_start", "rss_warm", "rss_end", "rss_max_after_warmup"):
        assert steps[key] > 0
    for key in (
        "steps_per_s_first",
        "steps_per_s_last",
        "steps_per_s_mean",
        "steps_per_cpu_s_first",
        "steps_per_cpu_s_last",
    ):
        assert steps[key] > 0 and math.isfinite(steps[key])
    assert made["creations"] == 10 and made["warmup_creations"] == 2
    assert [w["creations"] for w in made["windows"]] == [2, 10]
    assert made["rss_warm"] > 0 and made["rss_end"] > 0
    assert observations["bad"] == 0 and observations["examples"] == []
    # every agent's observation of every step and reset: 4 x (1,000 + 2) in the first
    # phase, 4 x 6 for each creation
    assert observations["checked"] == 4 * 1_002 + 10 * 4 * 6
    assert observations["checked_with_contains"] > 0
    text = format_report(report)
    assert "growth after warm-up" in text and "0 bad" in text


@pytest.mark.slow  # 1,000,000 agent-steps and 500 creations (1-3 min): make test-slow
def test_a_million_agent_steps_and_500_creations_leave_memory_flat():
    report = run_soak(1_000_000, 500)
    print(format_report(report))
    assert report["steps"]["agent_steps"] >= 1_000_000
    assert failures(report) == [], format_report(report)
    assert report["steps"]["growth_percent"] < MAX_GROWTH
    assert report["creations"]["growth_percent"] < MAX_GROWTH
    assert report["observations"]["bad"] == 0
