"""The benchmark's machinery (baselines/benchmark/, baselines/open_loop.py): a tiny run
that resumes, tiers kept apart, the calibration and learning curve recorded, open-loop play
searched and scored, the table's tier sections and curve figures rebuilt from JSON,
normalisation and IQM against hand-computed values, and the committed page up to date with
the committed JSON."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("tyro")

from baselines.benchmark import play  # noqa: E402
from baselines.benchmark.levels import LEVELS_OUT, read_levels, record, render_levels  # noqa: E402
from baselines.benchmark.page import listed_with_results, render  # noqa: E402
from baselines.benchmark.records import OUT, result_path, write_record  # noqa: E402
from baselines.benchmark.runs import run  # noqa: E402
from baselines.benchmark.settings import ROOT, SETTINGS, BenchmarkConfig, load_config  # noqa: E402
from baselines.benchmark.summary import build, scenario_summary, task_row, verdict  # noqa: E402

TASK = [("fruits_poisons", "scenario")]


TINY_PPO = "{num_envs: 1, num_steps: 16, num_minibatches: 2, update_epochs: 1, hidden: 16}"


def tiny_config(path: Path) -> BenchmarkConfig:
    path.write_text(
        "seeds: 2\nepisodes: 1\neval_seed: 100000\n"
        "open_loop: {candidates: 3, episodes: 1, hold: 4}\n"
        "tiers:\n"
        f"  smoke: {{seeds: 2, default: {{budget: 32, name: tiny, ppo: {TINY_PPO}}}}}\n"
        f"  standard: {{seeds: 1, default: {{budget: 64, name: tiny-1, ppo: {TINY_PPO}}}}}\n",
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
    assert ppo["tier"] == "smoke" and ppo["configuration"] == "tiny"
    assert ppo["calibration"]["matmuls_256_per_cpu_second"] > 0
    # 32 agent-steps end no 1000-step episode: a curve of 50 checkpoints without a point.
    assert ppo["curve"]["steps"][0] == 1 and ppo["curve"]["steps"][-1] == 32
    assert ppo["curve"]["returns"] == [None] * 50
    scripted = json.loads(result_path(out, "fruits_poisons", "scripted", 0).read_text())
    assert scripted["budget"] == 0 and scripted["agent_steps"] == 0
    assert "tier" not in scripted and scripted["calibration"]["matmuls_256_per_cpu_second"] > 0

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
    (row,) = summary["tiers"]["smoke"]["rows"]
    assert row["ppo"]["seeds"] == 2 and row["random"]["seeds"] == 2
    assert row["scripted"]["seeds"] == 1 and row["normalised"] is not None
    page = render(summary)
    smoke = page.split("## Smoke")[1].split("## Standard")[0]
    assert "`fruits_poisons`" in smoke and "not yet run" not in smoke.split("### Streams")[0]


def made_up(
    out: Path,
    task: str,
    method: str,
    scores,
    budget: int = 0,
    tier: str = "smoke",
    curves: list | None = None,
) -> None:
    for k, score in enumerate(scores):
        record: dict = {
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
        if method == "ppo" and tier != "smoke":
            record.update(
                tier=tier,
                configuration="made up",
                calibration={"matmuls_256_per_cpu_second": 1234.0 + k},
            )
        if curves is not None:
            record["curve"] = curves[k]
        write_record(result_path(out, task, method, k, tier), record)


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
    smoke = summary["tiers"]["smoke"]
    fruits, maze, key = smoke["rows"]

    # (score - 2) / (12 - 2): 0.5, 1, 1.5, 0; IQM = mean of the middle two = 0.75.
    assert fruits["normalised_seeds"] == pytest.approx([0.5, 1.0, 1.5, 0.0])
    assert fruits["normalised"]["iqm"] == pytest.approx(0.75)
    assert fruits["ppo"]["iqm"] == pytest.approx(9.5)  # the middle two of 2, 7, 12, 17
    assert fruits["random"]["iqm"] == pytest.approx(2.0)
    low, high = fruits["normalised"]["low"], fruits["normalised"]["high"]
    assert 0.0 <= low <= 0.75 <= high <= 1.5
    assert fruits["budget"] == 500 and fruits["cpu_seconds"] == 40.0  # PPO's 4 seeds
    assert fruits["verdict"] == "close to scripted"  # 0.5 <= 0.75 < 1 and high reaches 1

    assert maze["scale"]["ok"] is False and maze["normalised"] is None and maze["verdict"] == ""
    assert key["ppo"] is None and key["budget"] == 32  # the config's, for a task not yet run
    # Only the task with a scale counts in the aggregate: its pooled IQM is the task's.
    assert smoke["aggregate"]["tasks"] == 1
    assert smoke["aggregate"]["iqm"] == pytest.approx(0.75)
    assert summary["cpu_seconds"]["ppo"] == 60.0
    assert smoke["ppo_rate"] == 50.0  # 6 seeds of 500 agent-steps in 60 CPU seconds
    assert smoke["planned_steps"] == (500 + 500 + 32) * 2  # budgets (the tier's 2 seeds)
    # Priced at each task's own rate (50 agent-steps per CPU-second for both that ran;
    # key_door, not yet run, at the pooled rate): what is left is key_door's 2 seeds.
    hours = smoke["planned_hours"]
    assert hours["whole"] == pytest.approx((500 + 500 + 32) * 2 / 50 / 3600, abs=1e-4)
    assert hours["left"] == pytest.approx(32 * 2 / 50 / 3600, abs=1e-4)

    page = render(summary)
    assert "no scale: scripted does not beat random" in page
    assert "`key_door`" in page.split("### Not yet run (smoke)")[1].split("##")[0]
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
    assert summary["tiers"]["smoke"]["aggregate"]["iqm"] == pytest.approx(
        float(np.mean([1.0, 1.0]))
    )


@pytest.mark.parametrize(
    "text, key",
    [
        ("tiers: {smoke: {default: {budget: 10}}}\nbogus: 1\n", "bogus"),
        ("tiers: {smoke: {default: {budget: ten}}}\n", "tiers.smoke.default.budget"),
        ("tiers: {smoke: {default: {budget: 10, ppo: {no_such_option: 1}}}}\n", "no_such"),
        ("tiers: {smoke: {default: {budget: 10, ppo: {scenario: coop_carry}}}}\n", "scenario"),
        ("tiers: {standard: {default: {budget: 10}}}\n", "tiers.smoke: required"),
        ("tiers: {huge: {default: {budget: 10}}}\n", "tiers.huge"),
        ("tiers: {smoke: {default: {budget: 10, ppo: {preset: nope}}}}\n", "preset"),
        (
            "tiers: {smoke: {default: {budget: 10}, tasks: {coop_carry: {ppo: {shaping: 3.0}}}}}\n",
            "tasks.coop_carry.name",
        ),
        (
            "tiers: {smoke: {default: {budget: 10, ppo: "
            "{curriculum: baselines/curricula/coop_carry.yaml}}}}\n",
            "add up to 1,000,000 agent-steps, not the budget's 10",
        ),
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
    summary = build(OUT, load_config(SETTINGS), levels=LEVELS_OUT)
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


# -- tiers, open-loop play, calibration and curves ---------------------------------------


def test_tiers_are_kept_apart_and_each_resumes(tmp_path):
    config = tiny_config(tmp_path / "bench.yaml")
    out, runs = tmp_path / "results", tmp_path / "runs"
    smoke = run(config, TASK, ["random", "ppo"], out, runs)
    standard = run(config, TASK, ["random", "ppo"], out, runs, tier="standard")
    # Random play serves every tier: the standard tier adds only its PPO seed, apart.
    assert [p.relative_to(out).as_posix() for p in standard] == [
        "fruits_poisons/ppo/standard/seed_0.json"
    ]
    assert len(smoke) == 4
    record = json.loads(standard[0].read_text())
    assert record["tier"] == "standard" and record["configuration"] == "tiny-1"
    assert record["budget"] == 64 and record["agent_steps"] == 64
    assert record["calibration"]["matmuls_256_per_cpu_second"] > 0
    assert len(record["curve"]["steps"]) == 50 and record["curve"]["steps"][-1] == 64
    assert (runs / "standard" / "fruits_poisons" / "ppo" / "seed_0.safetensors").is_file()
    assert json.loads(result_path(out, "fruits_poisons", "ppo", 0).read_text())["budget"] == 32
    assert run(config, TASK, ["random", "ppo"], out, runs, tier="standard") == []
    assert run(config, TASK, ["random", "ppo"], out, runs) == []
    # Each tier reads its own PPO seeds and the shared random ones.
    summary = build(out, config, TASK)
    smoke_row = summary["tiers"]["smoke"]["rows"][0]
    standard_row = summary["tiers"]["standard"]["rows"][0]
    assert smoke_row["ppo"]["seeds"] == 2 and standard_row["ppo"]["seeds"] == 1
    assert smoke_row["budget"] == 32 and standard_row["budget"] == 64
    assert standard_row["random"]["seeds"] == 2 and standard_row["configuration"] == "tiny-1"


def test_a_tier_with_a_task_list_trains_only_those(tmp_path):
    path = tmp_path / "bench.yaml"
    path.write_text(
        "seeds: 1\nepisodes: 1\ntiers:\n"
        f"  smoke: {{default: {{budget: 32, ppo: {TINY_PPO}}}}}\n"
        "  certificate: {seeds: 1, only: [maze_goal],"
        f" default: {{budget: 32, ppo: {TINY_PPO}}}}}\n",
        encoding="utf-8",
    )
    config = load_config(path)
    tasks = [("fruits_poisons", "scenario"), ("maze_goal", "scenario")]
    written = run(
        config, tasks, ["ppo"], tmp_path / "results", tmp_path / "runs", tier="certificate"
    )
    assert [p.relative_to(tmp_path / "results").as_posix() for p in written] == [
        "maze_goal/ppo/certificate/seed_0.json"
    ]


def test_the_channels_ablation_is_trained_and_scored_without_it(tmp_path):
    """signal_rooms' follower hears the signaller: ``ppo_no_channel`` trains the task's
    configuration with --no-channel (a checkpoint with no hearing; without the channel the
    signaller's map and the follower's camera are one padded space's two entries), plays
    it in the scenario as it was trained (its ``overrides``), and runs only where there is
    a channel; the page sets it beside PPO."""
    config = tiny_config(tmp_path / "bench.yaml")
    out, runs = tmp_path / "results", tmp_path / "runs"
    tasks = [("fruits_poisons", "scenario"), ("signal_rooms", "scenario")]
    written = run(config, tasks, ["ppo_no_channel"], out, runs, tier="standard")
    assert [p.relative_to(out).as_posix() for p in written] == [
        "signal_rooms/ppo_no_channel/standard/seed_0.json"
    ]
    record = json.loads(written[0].read_text())
    assert record["options"]["no_channel"] is True and len(record["episodes"]) == 1
    assert record["configuration"] == "tiny-1, without the channel"
    assert record["curve"] is not None
    checkpoint = runs / "standard" / "signal_rooms" / "ppo_no_channel" / "seed_0.safetensors"
    assert play.trained_overrides(str(checkpoint)) == {"channel": None}
    assert play.trained_overrides("") == {}
    summary = build(out, config, tasks)
    rows = {r["task"]: r for r in summary["tiers"]["standard"]["rows"]}
    assert rows["signal_rooms"]["ppo_no_channel"]["seeds"] == 1
    assert rows["signal_rooms"]["channel_helps"] == ""  # no PPO with the channel yet
    assert not rows["fruits_poisons"]["no_channel_learner"]
    page = render(summary)
    section = page.split("### Without the channel (standard)")[1].split("###")[0]
    assert "`signal_rooms`" in section and "`fruits_poisons`" not in section
    assert "tiny-1, without the channel" in section


def test_the_channels_ablation_drops_the_channels_biases_and_says_so(tmp_path):
    path = tmp_path / "bench.yaml"
    path.write_text(
        "seeds: 1\nepisodes: 1\ntiers:\n"
        f"  smoke: {{default: {{budget: 32, ppo: {TINY_PPO}}},\n"
        "    tasks: {signal_rooms: {name: biased, ppo: {listening: 0.05, signalling: 0.05}}}}\n",
        encoding="utf-8",
    )
    tier = load_config(path).tier("smoke")
    assert tier.task("signal_rooms").ppo["listening"] == 0.05
    ablation = tier.task("signal_rooms", "ppo_no_channel")
    assert ablation.name == "biased, without the channel and its biases"
    assert ablation.ppo["no_channel"] is True
    assert not {"listening", "signalling"} & set(ablation.ppo)
    assert tier.task("fruits_poisons", "ppo_no_channel").name == "defaults, without the channel"


@pytest.mark.parametrize(
    ("with_it", "without", "helps"),
    [
        ([5, 6, 7], [0, 1, 0], "yes"),
        ([0, 1, 0], [5, 6, 7], "no"),
        ([1, 5, 9], [2, 6, 8], "not shown"),
    ],
)
def test_the_channel_helps_where_ppos_interval_lies_above_the_ablations(with_it, without, helps):
    def records(scores, configuration):
        return [
            {
                "score": s,
                "seed": k,
                "cpu_seconds": 60.0,
                "configuration": configuration,
                "budget": 1_000_000,
                "agent_steps": 1_000_000,
                "commit": "abc1234",
            }
            for k, s in enumerate(scores)
        ]

    config = load_config(SETTINGS)
    methods = {"ppo": records(with_it, "x"), "ppo_no_channel": records(without, "x, deaf")}
    row = task_row("signal_maps", "scenario", methods, config, "standard")
    assert row["channel_helps"] == helps and row["no_channel_learner"]
    assert row["no_channel_configuration"] == "x, deaf"
    assert row["no_channel_cpu_seconds"] == [60.0] * 3


def test_a_preset_does_not_replace_the_budget(tmp_path):
    from baselines.benchmark.settings import TaskConfig
    from baselines.benchmark.train import ppo_args

    task = TaskConfig(budget=1_000_000, name="p", ppo={"preset": "fruits_poisons"})
    args = ppo_args("fruits_poisons", 3, task, tmp_path / "seed_3.csv")
    # The preset asks for 2.6M agent-steps and 16 worlds; the budget (the learner's default
    # length, which a preset would otherwise fill) stays.
    assert args.total_timesteps == 1_000_000 and args.num_envs == 16 and args.ent_coef == 0.03
    assert args.preset == "" and args.seed == 3
    task = TaskConfig(
        budget=1_000_000, name="c", ppo={"curriculum": "baselines/curricula/coop_carry.yaml"}
    )
    assert Path(ppo_args("coop_carry", 0, task, tmp_path / "s.csv").curriculum).is_file()


def test_the_shipped_settings_name_every_tier_and_configuration():
    config = load_config(SETTINGS)
    assert list(config.tiers) == ["smoke", "standard", "certificate"]
    assert config.task("fruits_poisons").budget == 200_000  # smoke, as before the tiers
    assert (
        config.tier("standard").seeds == 5 and config.task("maze_goal", "standard").budget == 10**6
    )
    assert config.tier("certificate").default.budget == 10**7
    coop = config.task("coop_carry", "standard")
    assert coop.ppo["team_reward"] is True and "curriculum" in coop.name
    from baselines.benchmark.play import list_tasks

    shipped = {name for name, _ in list_tasks()}
    for tier in config.tiers.values():
        assert set(tier.tasks) | set(tier.only or []) <= shipped


def test_open_loop_play_ignores_what_it_sees_and_keeps_the_best_schedule():
    import gymnasium

    from baselines.open_loop import OpenLoopPolicy, best_of, schedule

    rng = np.random.default_rng(0)
    actions = schedule(gymnasium.spaces.Discrete(5), 200, 4, rng)
    assert len(actions) == 200 and set(actions) <= set(range(5))
    runs = [len(list(g)) for _, g in __import__("itertools").groupby(actions)]
    assert max(runs) >= 2  # actions are held
    policy = OpenLoopPolicy(actions)
    first = [policy.act(np.full(3, k)) for k in range(10)]
    policy.reset()
    assert [policy.act(None) for _ in range(10)] == first == actions[:10]

    class Env:
        step_limit = 20

        def action_space(self, agent):
            return gymnasium.spaces.Discrete(3)

    class Config:
        candidates, episodes, hold = 5, 2, 3

    seen = []

    def play(policies, seeds):  # a made-up task: the score is the first action taken
        seen.append(list(seeds))
        return [float(policies["a"].act(None)) + s for s in range(len(seeds))]

    plan, search = best_of(Env(), ["a"], play, Config(), seed=7, first_seed=500)
    assert seen == [[500, 501]] * 5 and len(search["training_scores"]) == 5
    assert search["training_score"] == max(search["training_scores"])
    assert plan["a"][0] + 0.5 == search["training_score"]
    again, _ = best_of(Env(), ["a"], play, Config(), seed=7, first_seed=500)
    assert again == plan  # drawn from the seed alone


def test_open_loop_is_run_and_scored_like_the_other_methods(tmp_path):
    config = tiny_config(tmp_path / "bench.yaml")
    out = tmp_path / "results"
    written = run(config, [("signal_maps", "scenario")], ["open_loop"], out, tmp_path / "runs")
    assert [p.name for p in written] == ["seed_0.json", "seed_1.json"]
    record = json.loads(written[0].read_text())
    search = record["open_loop"]["signal_maps"]
    assert search["candidates"] == 3 and search["training_episodes"] == 1
    assert len(record["episodes"]) == 1 and record["score"] == record["episodes"][0]
    assert "tier" not in record and record["budget"] == 0


def test_a_seed_curve_averages_the_episodes_of_each_checkpoint(tmp_path):
    from baselines.benchmark.curves import seed_curve

    log = tmp_path / "seed_0.csv"
    rows = ["seed,episode,step,agent,return,wall_time"]
    # Two agents per episode; episodes end at steps 10, 20, 45 and 100.
    for episode, step, returns in (
        (0, 10, (1, 3)),
        (1, 20, (4, 4)),
        (2, 45, (0, 2)),
        (3, 100, (9, 9)),
    ):
        rows += [f"0,{episode},{step},agent_{a},{r},1.0" for a, r in enumerate(returns)]
    log.write_text("\n".join(rows) + "\n")
    curve = seed_curve(log, budget=100, points=4)
    assert curve["steps"] == [25, 50, 75, 100]
    # (2 + 4) / 2 in the first quarter, 1 in the second, none in the third, 9 at the end.
    assert curve["returns"] == [3.0, 1.0, None, 9.0]


def test_a_task_curve_is_the_iqm_over_seeds_with_its_interval():
    from baselines.benchmark.curves import task_curve

    curves = [{"steps": [10, 20], "returns": [value, 5.0]} for value in (1.0, 2.0, 3.0, 4.0)] + [
        {"steps": [10, 20], "returns": [100.0, None]}
    ]
    got = task_curve(curves)
    assert got["seeds"] == [5, 4]
    assert got["iqm"][0] == pytest.approx(3.0)  # the middle three of 1, 2, 3, 4, 100
    assert got["low"][0] <= 3.0 <= got["high"][0] and got["high"][0] <= 100.0
    assert got["iqm"][1] == got["low"][1] == got["high"][1] == 5.0  # every seed alike
    with pytest.raises(ValueError, match="different checkpoints"):
        task_curve([{"steps": [1], "returns": [0.0]}, {"steps": [2], "returns": [0.0]}])


def test_the_page_has_a_section_per_tier_and_each_scenario_its_curve(tmp_path):
    from baselines.benchmark.table import write

    config_path = tmp_path / "bench.yaml"
    tiny_config(config_path)
    out, docs = tmp_path / "results", tmp_path / "docs"
    curve = {"steps": [32, 64], "returns": [1.0, 8.0]}
    made_up(out, "fruits_poisons", "random", [0.0, 2.0, 4.0])
    made_up(out, "fruits_poisons", "scripted", [12.0])
    made_up(out, "fruits_poisons", "open_loop", [3.0, 3.5, 4.0])
    made_up(out, "fruits_poisons", "ppo", [5.0, 6.0], budget=32)
    made_up(out, "fruits_poisons", "ppo", [11.0, 12.0, 13.0], 64, "standard", [curve] * 3)
    made_up(out, "maze_goal", "random", [0.0])
    made_up(out, "maze_goal", "scripted", [10.0])
    made_up(out, "maze_goal", "open_loop", [6.0, 7.0])
    made_up(out, "maze_goal", "ppo", [1.0, 2.0], 64, "standard")
    summary = write(out, config_path, levels=tmp_path / "no_levels", docs=docs)
    page = (docs / "benchmark.md").read_text()
    smoke = page.split("## Smoke: 32 agent-steps x 2 seeds")[1].split("## Standard")[0]
    standard = page.split("## Standard: 64 agent-steps x 1 seeds")[1].split("## Provenance")[0]
    assert "`maze_goal`" in smoke.split("### Not yet run (smoke)")[1]
    fruits = next(x for x in standard.splitlines() if x.startswith("| `fruits_poisons` |"))
    # The configuration the records name, not the settings' (tiny-1, for tasks not yet run).
    assert (
        fruits.startswith("| `fruits_poisons` | 12 (11 to 13) |") and "| made up | 64 |" in fruits
    )
    # PPO's interval (11 to 13) above open-loop's (3 to 4): beaten; on maze_goal below it.
    rows = {r["task"]: r for r in summary["tiers"]["standard"]["rows"]}
    assert rows["fruits_poisons"]["beats_open_loop"] == "yes"
    assert rows["maze_goal"]["beats_open_loop"] == "no"
    assert "| **no** |" in standard and "not shown on `maze_goal`" in standard
    assert "| 1234 |" in standard and "| 1235 |" in standard  # each seed's calibration
    assert "not recorded" in smoke  # smoke's made-up seeds have none
    assert (docs / "images" / "benchmark.png").is_file()
    assert (docs / "images" / "benchmark_standard.png").is_file()
    assert [p.name for p in summary["curves"]] == ["fruits_poisons.png"]  # the only curves
    assert (docs / "images" / "curves" / "fruits_poisons.png").stat().st_size > 1000
    shown = json.loads((out / "summary.json").read_text())
    assert shown["fruits_poisons"]["tier"] == "standard" and shown["fruits_poisons"]["budget"] == 64
    assert set(shown["fruits_poisons"]["tiers"]) == {"smoke", "standard"}


def test_a_scenario_page_shows_its_curve_only_when_drawn(tmp_path, monkeypatch):
    import sys

    monkeypatch.syspath_prepend(str(ROOT / "docs" / "_ext"))
    scenario_page = __import__("scenario_page")
    monkeypatch.setattr(scenario_page, "DOCS", tmp_path)
    assert scenario_page.curve_section("fruits_poisons", tmp_path / "scenarios") == []
    (tmp_path / "images" / "curves").mkdir(parents=True)
    (tmp_path / "images" / "curves" / "fruits_poisons.png").write_bytes(b"png")
    lines = scenario_page.curve_section("fruits_poisons", tmp_path / "scenarios")
    assert "```{image} ../images/curves/fruits_poisons.png" in lines
    sys.modules.pop("scenario_page", None)


def test_what_was_tried_is_checked_and_shown_on_the_scenario_page(tmp_path, monkeypatch):
    import sys

    from flatland_ma.scenario.shipped import list_scenarios

    monkeypatch.syspath_prepend(str(ROOT / "docs" / "_ext"))
    tried = __import__("tried")
    shipped = tried.load()  # the committed file is well formed, of tasks that exist
    streams = {p.stem for p in (ROOT / "scenarios" / "streams").glob("*.yaml")}
    assert shipped and set(shipped) <= set(list_scenarios()) | streams
    for entry in shipped.values():
        for attempt in entry.tried:
            page, _, anchor = attempt.where.partition("#")
            text = (ROOT / page).read_text(encoding="utf-8")
            assert not anchor or any(
                line.startswith("#") and _slug(line) == anchor for line in text.splitlines()
            ), attempt.where
    lines = tried.tried_section("explore_goal", ROOT / "docs" / "scenarios")
    assert lines[0] == "### What was tried" and any("](../results.md#" in x for x in lines)
    assert any(x.startswith("**What blocks it.**") for x in lines)
    assert tried.tried_section("fruits_poisons", ROOT / "docs" / "scenarios") == []
    bad = tmp_path / "tried.yaml"
    bad.write_text("key_door:\n  tried:\n    - {what: x, agent_steps: 0, seeds: 1}\n")
    with pytest.raises(ValueError, match="agent_steps"):
        tried.load(bad)
    sys.modules.pop("tried", None)


def _slug(heading: str) -> str:
    """The anchor MyST gives a Markdown heading (lower case, words joined by hyphens)."""
    words = "".join(c for c in heading.lstrip("#").strip().lower() if c.isalnum() or c in " -")
    return "-".join(words.split())


def test_an_interrupted_ppo_seed_goes_on_from_its_checkpoint(tmp_path, monkeypatch):
    from baselines import ppo
    from baselines.benchmark import train
    from baselines.ppo_resume import periodic_checkpoints

    config = tiny_config(tmp_path / "bench.yaml")
    out, runs = tmp_path / "results", tmp_path / "runs"
    monkeypatch.setattr(train, "RESUME_EVERY", 1)
    iterate = ppo.Training.iterate

    def stop_at_the_fourth(self, iteration, start):
        if iteration == 4:
            raise KeyboardInterrupt
        iterate(self, iteration, start)

    with monkeypatch.context() as patch:
        patch.setattr(ppo.Training, "iterate", stop_at_the_fourth)
        with pytest.raises(KeyboardInterrupt):
            run(config, TASK, ["ppo"], out, runs, tier="standard")
    folder = runs / "standard" / "fruits_poisons" / "ppo" / "seed_0"
    assert [p.name for p in periodic_checkpoints(folder)] == ["update_00003.safetensors"]
    (written,) = run(config, TASK, ["ppo"], out, runs, tier="standard")
    record = json.loads(written.read_text())
    assert record["resumed_at"] == [48] and record["agent_steps"] == 64  # 3 of 4 updates
    assert periodic_checkpoints(folder) == []  # nothing left to go on from


def test_a_tier_is_priced_at_each_tasks_own_rate_from_any_tier():
    from baselines.benchmark.summary import planned_hours, task_rates

    record = {"agent_steps": 3600, "cpu_seconds": 10.0}
    rates = task_rates({"standard": {"a": {"ppo": [record, record]}, "b": {"random": [record]}}})
    assert rates == {"a": 360.0}  # PPO records only
    rows = [
        {"task": "a", "learner": True, "budget": 36_000, "ppo": {"seeds": 1}},
        {"task": "b", "learner": True, "budget": 3_600, "ppo": None},
        {"task": "c", "learner": False, "budget": 0, "ppo": None},
    ]
    # a: 3 seeds of 100 CPU-seconds, 1 done; b at the pooled 36 a second: 3 of 100 s.
    assert planned_hours(rows, 3, rates, 36.0) == {
        "whole": round(600 / 3600, 4),
        "left": round(500 / 3600, 4),
    }
    assert planned_hours(rows, 3, {}, None) is None


def test_a_tier_counts_the_tasks_of_its_list_that_have_results():
    """A task run at a tier it has since left (a seed kept, not on the tier's list) is not
    counted among the list's tasks with results."""
    rows = [
        {"ppo": 1.0, "learner": True},
        {"ppo": 1.0, "learner": False},
        {"ppo": None, "learner": True},
    ]
    assert listed_with_results(rows) == "1 of 2"
