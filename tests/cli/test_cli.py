"""The flatland-ma command, through its entry point in a subprocess and in-process."""

import subprocess
import sys

import pytest

import flatland_ma
from flatland_ma.bench.throughput import (
    BENCHED,
    BenchResult,
    bench_batched,
    bench_gym,
    bench_parallel,
    comparisons,
    format_table,
)
from flatland_ma.cli import main


def test_list_prints_every_scenario_on_one_line():
    out = subprocess.run(
        [sys.executable, "-m", "flatland_ma.cli", "list"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    lines = out.strip().splitlines()
    assert len(lines) == len(flatland_ma.list_scenarios()) >= 10
    (line,) = [x for x in lines if x.startswith("fruits_poisons ")]
    assert "flatland_ma/FruitsPoisons-v0" in line and "The paper's task" in line


def test_record_writes_a_gif_and_a_png(tmp_path, capsys):
    out = tmp_path / "clip.gif"
    assert main(["record", "fruits_poisons_multi", "--steps", "6", "--out", str(out)]) == 0
    assert out.exists() and out.with_suffix(".png").exists()


def test_demo_prints_scores_for_both_policies(tmp_path, capsys):
    assert main(["demo", "--episodes", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "greedy (scripted)" in out and "random (uniform)" in out
    assert (tmp_path / "fruits_poisons.gif").exists()


def test_bench_measures_env_and_bare_physics():
    results = [bench_gym("fruits_poisons", 300), bench_parallel("fruits_poisons_multi", 300)]
    results.append(bench_batched("fruits_poisons_multi", 64))
    assert results[0].agents == 1 and results[1].agents == 4 and results[2].agents == 4
    for r in results:  # rates, not a race: a busy machine may slow either measurement
        assert r.env_steps_per_s > 0 and r.bare_steps_per_s > 0
    table = format_table(results)
    assert "bare space.step/s" in table and "fruits_poisons_multi" in table
    assert BenchResult("x", 4, 10.0, 100.0).agent_steps_per_s == 40.0


def test_bench_compares_large_worlds_and_bodies_with_parts_with_their_references():
    fake = [
        BenchResult("gym flatland_ma/FruitsPoisons-v0", 1, 20_000.0, 1e6),
        BenchResult("parallel fruits_poisons_multi", 4, 10_000.0, 1e6),
        BenchResult("gym flatland_ma/MazeLarge-v0", 1, 16_000.0, 1e6),
        BenchResult("parallel tug_of_war", 4, 5_000.0, 1e6),
    ]
    ratios = dict(comparisons(fake))
    assert len(ratios) == 2
    (large,) = [r for text, r in ratios.items() if "largest layout" in text]
    (parts,) = [r for text, r in ratios.items() if "bodies with parts" in text]
    assert large == pytest.approx(1.25) and parts == pytest.approx(2.0)
    assert "1.25x slower" in format_table(fake) and "2.00x slower" in format_table(fake)
    # The full bench measures every environment these comparisons need.
    assert {"maze_large", "tug_of_war"} <= {scenario for _, scenario in BENCHED}


def test_a_recording_keeps_the_first_frame_and_the_one_that_ends_the_episode(tmp_path, monkeypatch):
    import flatland_ma.render.video as video
    from flatland_ma.policies import CarrierPolicy

    kept = []
    monkeypatch.setattr(video, "save_gif", lambda frames, out, fps: kept.extend(frames) or out)
    # One frame in 1,000: only the first, and the last when the box goes into the goal.
    args = ["record", "push_box", "--policy", "carrier", "--every", "1000", "--seed", "1"]
    assert main([*args, "--out", str(tmp_path / "clip.gif")]) == 0
    env = flatland_ma.parallel_env("push_box", render_mode="rgb_array")
    observations, _ = env.reset(seed=1)
    first, policy = env.render(), CarrierPolicy(env, "agent_0")
    while env.agents:
        _, _, _, _, infos = env.step({"agent_0": policy.act(observations["agent_0"])})
    assert infos["agent_0"]["deliveries"] == 1
    assert len(kept) == 2
    assert (kept[0] == first).all() and (kept[-1] == env.render()).all()


def test_list_into_a_reader_that_leaves_early_prints_no_traceback():
    """``flatland-ma list | head -1``: the pipe closes after one line."""
    import subprocess
    import sys

    process = subprocess.Popen(
        [sys.executable, "-m", "flatland_ma.cli", "list"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        bufsize=0,
    )
    assert process.stdout is not None and process.stderr is not None
    first = process.stdout.read(20)
    process.stdout.close()
    error = process.stderr.read().decode()
    assert process.wait(timeout=600) == 0  # a guard against a hang, not a time to beat
    assert first and "Traceback" not in error and "BrokenPipe" not in error


def test_bench_reports_what_each_sensor_kind_costs():
    from flatland_ma.bench.sensors import SETUPS, format_costs, sensor_costs

    costs = sensor_costs(steps=50)
    assert [c.label for c in costs[: len(SETUPS)]] == [label for label, _ in SETUPS]
    assert len(costs) == len(SETUPS) + 3  # and touch's logging, a smell search, the global state
    assert costs[-3].label.startswith("touch:")  # a difference of two timings: any sign
    assert costs[-2].label.startswith("smell:") and costs[-2].micros_per_agent_step > 0
    assert all(c.micros_per_agent_step > 0 for c in costs[: len(SETUPS)] + costs[-1:])
    assert all(c.label in format_costs(costs) for c in costs)


def test_bench_prints_json_for_machines(capsys):
    import json

    assert main(["bench", "--steps", "160", "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    labels = [row["environment"] for row in figures["environments"]]
    assert len(labels) == len(BENCHED) and any(label.startswith("batched") for label in labels)
    for row in figures["environments"]:
        assert row["agent_steps_per_s"] == row["env_steps_per_s"] * row["agents"] > 0
        assert row["bare_space_step_per_s"] > 0
    assert figures["sensing"][0]["setup"].startswith("camera")


def test_bench_at_scale_measures_one_process_and_every_core(capsys, monkeypatch):
    import json

    from flatland_ma.bench import scale as bench_scale

    monkeypatch.setattr(bench_scale, "cores", lambda: 2)
    monkeypatch.setattr(bench_scale, "TARGET_WORLDS", 2)
    monkeypatch.setattr(bench_scale, "BUSY_WORLDS", 2)
    assert (
        main(["bench", "--scale", "--worlds", "1,2", "--seconds", "0.1", "--no-ppo", "--json"]) == 0
    )
    figures = json.loads(capsys.readouterr().out)
    every = {r["environment"]: r for r in figures["batched"]}
    rows = {name: row for name, row in every.items() if name.endswith(("process", "processes"))}
    assert set(rows) == {
        f"batched {s} x {n}, {p}"
        for s in ("fruits_poisons", "fruits_poisons_multi")
        for n, p in ((1, "1 process"), (2, "1 process"), (2, "2 processes"))
    }
    targets = {name: row for name, row in every.items() if name not in rows}
    assert set(targets) == {
        "make_vec flatland_ma/FruitsPoisons-v0 x 2",
        "make flatland_ma/FruitsPoisons-v0",
        "batched fruits_poisons_multi x 2, one thread",
        "batched fruits_poisons_multi x 2, threads, a busy process holding one core",
    }
    for name, row in targets.items():
        assert row["world_steps_per_s"] > 0 and row["threads"] and "busy" in row
        assert (row["bare_space_step_per_s"] is None) == name.startswith("batched")
    assert figures["rays"]["rays_per_s_per_core"] > 0
    for name, row in rows.items():
        agents = 4 if "multi" in name else 1
        assert row["agents"] == agents
        assert row["agent_steps_per_s"] == pytest.approx(agents * row["world_steps_per_s"])
        assert row["world_steps_per_s"] > 0 and row["bare_space_step_per_s"] > 0
    assert figures["training"] == []
    assert main(["bench", "--scale", "--worlds", "0"]) == 2
    assert "argument --worlds: '0'" in capsys.readouterr().err


def test_bench_times_ppo_end_to_end_from_a_checkout(tmp_path):
    from flatland_ma.bench.scale import bench_ppo

    rate = bench_ppo(steps=512, worlds=1)
    assert rate.agent_steps_per_s and rate.agent_steps_per_s > 0, rate.note
    missing = bench_ppo(steps=512, worlds=1, root=tmp_path)
    assert missing.agent_steps_per_s is None and "checkout" in missing.note
