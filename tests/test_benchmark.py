"""The benchmark's machinery (baselines/benchmark*.py): a tiny run that resumes, the table
rebuilt from its JSON, normalisation and IQM against hand-computed values, and the
committed page up to date with the committed JSON."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("tyro")

from baselines.benchmark import OUT, ROOT, result_path, run, write_record  # noqa: E402
from baselines.benchmark_config import BenchmarkConfig, load_config  # noqa: E402
from baselines.benchmark_table import (  # noqa: E402
    build,
    render,
    scenario_summary,
    verdict,
)
from baselines.levels import LEVELS_OUT, read_levels, record, render_levels  # noqa: E402

TASK = [("fruits_poisons", "scenario")]


def tiny_config(path: Path) -> BenchmarkConfig:
    path.write_text(
        "seeds: 2\nepisodes: 1\neval_seed: 100000\n"
        "default: {budget: 32, ppo: {num_envs: 1, num_steps: 16, num_minibatches: 2,"
        " update_epochs: 1, hidden: 16}}\n",
        encoding="utf-8",
    )
    return load_config(path)


def test_a_tiny_run_writes_every_seed_then_resumes_skipping_done_ones(tmp_path):
    config = tiny_config(tmp_path / "bench.yaml")
    out, runs = tmp_path / "results", tmp_path / "runs"
    written = run(config, TASK, ["random", "scripted", "ppo"], out, runs)
    # The greedy forager draws no random numbers: one scripted seed stands for all.
    assert sorted(p.relative_to(out).as_posix() for p in written) == [
        f"fruits_poisons/{m}/seed_{k}.json"
        for m, seeds in (("ppo", 2), ("random", 2), ("scripted", 1))
        for k in range(seeds)
    ]
    ppo = json.loads(result_path(out, "fruits_poisons", "ppo", 1).read_text())
    assert ppo["budget"] == 32 and ppo["agent_steps"] == 32  # two updates of 16 steps, 1 slot
    assert ppo["options"]["num_envs"] == 1 and len(ppo["episodes"]) == 1
    assert ppo["score"] == ppo["episodes"][0]
    assert ppo["cpu_seconds"] > 0 and ppo["wall_seconds"] > 0
    assert ppo["versions"]["torch"] and ppo["commit"] and "load_1min" in ppo["machine"]["after"]
    assert (runs / "fruits_poisons" / "ppo" / "seed_1.safetensors").is_file()
    scripted = json.loads(result_path(out, "fruits_poisons", "scripted", 0).read_text())
    assert scripted["budget"] == 0 and scripted["agent_steps"] == 0

    # Resumed: nothing is redone; a lost seed is the only one run again.
    stamps = {p: p.stat().st_mtime_ns for p in written}
    assert run(config, TASK, ["random", "scripted", "ppo"], out, runs) == []
    assert all(p.stat().st_mtime_ns == t for p, t in stamps.items())
    lost = result_path(out, "fruits_poisons", "random", 0)
    lost.unlink()
    assert run(config, TASK, ["random", "scripted", "ppo"], out, runs) == [lost]
    assert all(p.stat().st_mtime_ns == t for p, t in stamps.items() if p != lost)

    # The table reads what was written.
    summary = build(out, config, TASK)
    (row,) = summary["rows"]
    assert row["ppo"]["seeds"] == 2 and row["random"]["seeds"] == 2
    assert row["scripted"]["seeds"] == 1 and row["normalised"] is not None
    page = render(summary)
    assert "`fruits_poisons`" in page and "not yet run" not in page.split("## Streams")[0]


def made_up(out: Path, task: str, method: str, scores, budget: int = 0) -> None:
    for k, score in enumerate(scores):
        record = {
            "task": task,
            "kind": "scenario",
            "method": method,
            "seed": k,
            "score": score,
            "budget": budget,
            "agent_steps": budget,
            "cpu_seconds": 10.0,
            "commit": "abc1234",
            "versions": {"python": "3"},
        }
        write_record(result_path(out, task, method, k), record)


def test_normalisation_iqm_and_verdicts_on_made_up_numbers(tmp_path):
    config = tiny_config(tmp_path / "bench.yaml")
    out = tmp_path / "results"
    made_up(out, "fruits_poisons", "random", [0.0, 2.0, 4.0])  # mean 2
    made_up(out, "fruits_poisons", "scripted", [10.0, 12.0, 14.0])  # mean 12
    made_up(out, "fruits_poisons", "ppo", [7.0, 12.0, 17.0, 2.0], budget=500)
    made_up(out, "maze_goal", "random", [5.0, 5.0])
    made_up(out, "maze_goal", "scripted", [5.0, 5.0])  # no better than random: no scale
    made_up(out, "maze_goal", "ppo", [9.0, 9.0], budget=500)
    tasks = [("fruits_poisons", "scenario"), ("maze_goal", "scenario"), ("key_door", "scenario")]
    summary = build(out, config, tasks)
    fruits, maze, key = summary["rows"]

    # (score - 2) / (12 - 2): 0.5, 1, 1.5, 0; IQM = mean of the middle two = 0.75.
    assert fruits["normalised_seeds"] == pytest.approx([0.5, 1.0, 1.5, 0.0])
    assert fruits["normalised"]["iqm"] == pytest.approx(0.75)
    assert fruits["ppo"]["iqm"] == pytest.approx(9.5)  # the middle two of 2, 7, 12, 17
    assert fruits["random"]["iqm"] == pytest.approx(2.0)
    low, high = fruits["normalised"]["low"], fruits["normalised"]["high"]
    assert 0.0 <= low <= 0.75 <= high <= 1.5
    assert fruits["budget"] == 500 and fruits["cpu_seconds"] == 100.0
    assert fruits["verdict"] == "close to scripted"  # 0.5 <= 0.75 < 1 and high reaches 1

    assert maze["scale"]["ok"] is False and maze["normalised"] is None and maze["verdict"] == ""
    assert key["ppo"] is None and key["budget"] == 32  # the config's, for a task not yet run
    # Only the task with a scale counts in the aggregate: its pooled IQM is the task's.
    assert summary["aggregate"]["tasks"] == 1
    assert summary["aggregate"]["iqm"] == pytest.approx(0.75)
    assert summary["cpu_seconds"]["ppo"] == 60.0
    assert summary["ppo_rate"] == 50.0  # 6 seeds of 500 agent-steps in 60 CPU seconds
    assert summary["planned_steps"] == (500 + 500 + 32) * 2  # budgets (the config's 2 seeds)

    page = render(summary)
    assert "no scale: scripted does not beat random" in page
    assert "`key_door`" in page.split("## Not yet run")[1]
    assert "0.75" in page

    assert verdict({"iqm": 1.2, "low": 1.05, "high": 1.4}) == "beyond scripted"
    assert verdict({"iqm": 1.2, "low": 0.9, "high": 1.4}) == "solved"
    assert verdict({"iqm": 0.4, "low": 0.1, "high": 1.4}) == "open"
    assert verdict({"iqm": 0.8, "low": 0.6, "high": 0.95}) == "open"
    assert verdict({"iqm": 0.8, "low": 0.6, "high": 1.1}) == "close to scripted"


def test_the_aggregate_pools_the_tasks_seeds(tmp_path):
    config = tiny_config(tmp_path / "bench.yaml")
    out = tmp_path / "results"
    for task, ppo in (("fruits_poisons", [0.0, 10.0]), ("maze_goal", [20.0, 30.0])):
        made_up(out, task, "random", [0.0])
        made_up(out, task, "scripted", [10.0 if task == "fruits_poisons" else 20.0])
        made_up(out, task, "ppo", ppo)
    tasks = [("fruits_poisons", "scenario"), ("maze_goal", "scenario")]
    summary = build(out, config, tasks)
    # Normalised: 0, 1 and 1, 1.5; their IQM is the mean of the middle two, 1 and 1.
    assert summary["aggregate"]["iqm"] == pytest.approx(float(np.mean([1.0, 1.0])))


@pytest.mark.parametrize(
    "text, key",
    [
        ("default: {budget: 10}\nbogus: 1\n", "bogus"),
        ("default: {budget: ten}\n", "default.budget"),
        ("default: {budget: 10, ppo: {no_such_option: 1}}\n", "no_such_option"),
        ("default: {budget: 10, ppo: {scenario: coop_carry}}\n", "scenario"),
    ],
)
def test_a_bad_config_fails_naming_the_key(tmp_path, text, key):
    path = tmp_path / "bench.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=key):
        load_config(path)


def test_the_page_is_up_to_date_with_the_committed_results():
    """docs/benchmark.md and results/benchmark/summary.json are written from the committed
    JSON: rebuild them with ``make benchmark-table``."""
    summary = build(OUT, load_config(ROOT / "baselines" / "benchmark.yaml"), levels=LEVELS_OUT)
    written = (ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8")
    assert written == render(summary), "docs/benchmark.md is out of date: make benchmark-table"
    shown = json.loads((OUT / "summary.json").read_text(encoding="utf-8"))
    assert shown == json.loads(json.dumps(scenario_summary(summary))), "make benchmark-table"


def test_the_fast_iqm_is_scipys_trim_mean():
    from scipy.stats import trim_mean

    from flatland_ma.evaluation.stats import iqm

    rng = np.random.default_rng(0)
    for n in range(1, 40):
        scores = rng.normal(size=n) * 100
        assert iqm(scores) == pytest.approx(trim_mean(scores, 0.25), rel=1e-12, abs=1e-12)


def test_a_stream_is_scored_on_each_of_its_tasks(tmp_path):
    config = tiny_config(tmp_path / "bench.yaml")
    out = tmp_path / "results"
    tasks = [("cross_objective", "stream")]
    (path,) = run(config, tasks, ["random"], out, tmp_path / "runs")[:1]
    record = json.loads(path.read_text())
    labels = ["paper", "swapped", "berries", "scarce", "neutral"]
    assert list(record["parts"]) == labels and len(record["episodes"]) == len(labels)
    assert record["score"] == pytest.approx(np.mean(list(record["parts"].values())))
    assert record["parts"] == dict(zip(labels, record["episodes"]))  # one episode each


def test_ppo_lives_the_never_ending_stream_and_is_scored_on_its_first_steps(tmp_path):
    config = tiny_config(tmp_path / "bench.yaml")
    config = config.model_copy(update={"never_ending_steps": 20})
    out, runs = tmp_path / "results", tmp_path / "runs"
    (path,) = run(config, [("never_ending", "stream")], ["ppo"], out, runs)[:1]
    record = json.loads(path.read_text())
    assert record["budget"] == 32 and record["agent_steps"] == 32  # no episode ever ended
    checkpoint = runs / "never_ending" / "ppo" / "seed_0.safetensors"
    assert checkpoint.is_file()
    # Scored as random and scripted play are: the held-out episodes, 20 steps each.
    assert len(record["episodes"]) == 1 and record["score"] == record["episodes"][0]


def _fake_run(tmp_path: Path, returns: list[float], wall: float, agents: int = 1) -> Path:
    """A finished baselines.ppo run's log and JSON: one episode every 100 steps and second."""
    log = tmp_path / "seed_2.csv"
    rows = ["seed,episode,step,agent,return,score,fruits,poisons,wall_time"]
    for k, value in enumerate(returns):
        for a in range(agents):
            rows.append(f"2,{k},{100 * (k + 1)},agent_{a},{value},{value},0,0,{k + 1.0}")
    log.write_text("\n".join(rows) + "\n")
    args = {"scenario": "fruits_poisons", "seed": 2, "csv": str(log), "preset": "fruits_poisons"}
    run = {"args": args, "steps": 100 * len(returns), "wall_seconds": wall, "cpu_seconds": wall}
    log.with_suffix(".json").write_text(json.dumps(run))
    return log


def test_a_level_record_reads_the_last_50_and_when_the_level_was_first_reached(tmp_path):
    returns = [0.0] * 60 + [400.0] * 30 + [290.0] * 50  # the mean of 50 passes 300 on the way
    log = _fake_run(tmp_path, returns, wall=500.0)
    path = record("fruits_poisons_300", log, tmp_path / "levels")
    got = json.loads(path.read_text())
    assert got["last_50"] == 290.0
    means = [np.mean(returns[max(0, k - 49) : k + 1]) for k in range(49, len(returns))]
    assert got["best_50"] == pytest.approx(max(means))
    first = 49 + next(k for k, m in enumerate(means) if m >= 300)
    assert got["first_at_step"] == 100 * (first + 1) and got["first_at_wall"] == first + 1.0
    assert got["met"] is False  # 290 at the end: passing 300 on the way is not holding it
    log = _fake_run(tmp_path, [310.0] * 60, wall=700.0)
    slow = json.loads(record("fruits_poisons_300", log, tmp_path / "levels").read_text())
    assert slow["last_50"] == 310.0 and slow["met"] is False  # over the 10 minutes
    log = _fake_run(tmp_path, [310.0] * 60, wall=590.0, agents=2)
    fast = record("fruits_poisons_300", log, tmp_path / "levels", tag="fast")
    assert json.loads(fast.read_text())["met"] is True
    assert json.loads(fast.read_text())["episodes"] == 60
    lines = "\n".join(render_levels(read_levels(tmp_path / "levels")))
    assert "| `fast` | 2 | `preset` fruits_poisons |" in lines
    assert "| `ppo` | 2 | `preset` fruits_poisons |" in lines  # the slow run, kept apart
    assert (
        "**not met**: at best 1 of the 5 seeds it asks for, among runs of one setting (2 runs"
        in lines
    )
    assert "**not met**: no run recorded." in lines  # the cooperative levels, here unrun


def test_a_level_refuses_a_run_of_another_task(tmp_path):
    log = _fake_run(tmp_path, [1.0] * 60, wall=10.0)
    with pytest.raises(ValueError, match="not 'coop_carry'"):
        record("coop_carry_half", log, tmp_path / "levels")
