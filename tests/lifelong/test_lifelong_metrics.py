"""The continual-learning metrics against values worked out by hand on a small synthetic
run, the run folder's reader and its located errors, and ``flatland-ma lifelong report``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from flatland_ma.cli import main
from flatland_ma.lifelong.metrics import curve_mean, interval, life_metrics, normalise
from flatland_ma.lifelong.report import RunError, load_run, summarise

SEGMENTS = [(0, 0, 100), (1, 100, 200), (2, 200, 300)]
STEPS = np.array([0.0, 100.0, 200.0, 300.0])
RETURNS = np.array([[0, 0, 0], [10, 2, 0], [4, 8, 1], [2, 4, 9]], float)
"""Blocks (rows) by tasks: task 0 learnt then forgotten, task 1 half kept, task 2 last."""
REFERENCE = {0: [0, 5, 10], 1: [0, 10, 10], 2: [0, 0, 10]}
"""The reference learner alone on each task, at steps 0, 50 and 100: normalised (level 10)
its mean over the segment is 0.5, 0.75 and 0.25."""


def test_the_metrics_of_one_life_match_a_hand_computation():
    p = normalise(RETURNS, np.zeros(3), np.full(3, 10.0))
    ref = [(np.array([0.0, 50, 100]), np.array(REFERENCE[i]) / 10) for i in range(3)]
    m = life_metrics(STEPS, p, SEGMENTS, ref)
    # Final performance 0.2, 0.4, 0.9.
    assert m.average == pytest.approx((0.2 + 0.4 + 0.9) / 3)
    # Task 0: best from step 100 on (before the last block) 1.0, final 0.2; task 1: 0.8
    # then 0.4; task 2 ends the life: no forgetting to speak of.
    assert m.forgetting[:2] == pytest.approx([0.8, 0.4]) and math.isnan(m.forgetting[2])
    # Each task's curve rises linearly over its segment: 0 -> 1, 0.2 -> 0.8, 0.1 -> 0.9,
    # mean 0.5 each. Against the reference's 0.5, 0.75, 0.25:
    assert m.forward_transfer == pytest.approx([0.0, (0.5 - 0.75) / 0.25, (0.5 - 0.25) / 0.75])
    # Backward: (0.2 - 1.0 + 0.4 - 0.8) / 2.
    assert m.backward_transfer == pytest.approx(-0.6)


def test_a_task_trained_twice_is_measured_from_its_first_segment():
    segments = [(0, 0, 100), (1, 100, 200), (0, 200, 300), (1, 300, 400)]
    steps = np.array([0.0, 100, 200, 300, 400])
    p = np.array([[0, 0], [1, 0], [0.5, 1], [1, 0.2], [0.6, 0.9]])
    m = life_metrics(steps, p, segments)
    # Task 0: best of blocks at 100, 200, 300 is 1.0, final 0.6; task 1 from 200: 1.0 - 0.9.
    assert m.forgetting == pytest.approx([0.4, 0.1])
    assert m.backward_transfer == pytest.approx(((0.6 - 1.0) + (0.9 - 1.0)) / 2)
    assert np.isnan(m.forward_transfer).all()  # no reference given


def test_normalisation_and_curve_means():
    assert normalise(np.array([5.0, 10.0, 20.0]), 5.0, 15.0) == pytest.approx([0.0, 0.5, 1.5])
    with pytest.raises(ValueError, match="does not beat random"):
        normalise(np.array([1.0]), np.array([2.0]), np.array([2.0]))
    # A step from 0 to 1 at t=50 seen through blocks at 0, 50, 100 (linear between).
    assert curve_mean(np.array([0.0, 50, 100]), np.array([0.0, 1, 1]), 0, 100) == pytest.approx(
        0.75
    )
    assert curve_mean(np.array([0.0, 100]), np.array([2.0, 2.0]), 20, 60) == pytest.approx(2.0)


def test_the_interval_is_students_t_over_seeds():
    mean, low, high = interval([1.0, 3.0])
    # sd 2**0.5, n 2: half-width t(0.975, 1) * 1 = 12.706.
    assert mean == 2.0 and high - mean == pytest.approx(12.7062, abs=1e-3) and low < 0
    assert interval([0.5, 0.5, 0.5])[1:] == (0.5, 0.5)
    assert math.isnan(interval([0.3])[1]) and math.isnan(interval([float("nan")])[0])


def test_forgetting_needs_a_block_after_the_task_and_before_the_last():
    # Blocks only at the start and the end: task 0's training ends at 100, but no block
    # falls in [100, 300), so its forgetting is undefined, as the last task's is.
    steps = np.array([0.0, 300.0])
    m = life_metrics(steps, np.array([[0.0, 0, 0], [0.5, 0.6, 0.9]]), SEGMENTS)
    assert np.isnan(m.forgetting).all()
    # The average of the table is then over no task; with a block at 200 it is task 0's
    # and task 1's (the N-1 tasks before the last).
    m = life_metrics(STEPS, normalise(RETURNS, np.zeros(3), np.full(3, 10.0)), SEGMENTS)
    assert np.count_nonzero(~np.isnan(m.forgetting)) == 2


def write_run(folder, seeds=(0, 1), shift=0.0):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "stream.json").write_text(
        json.dumps(
            {
                "stream": "toy",
                "tasks": ["a", "b", "c"],
                "segments": SEGMENTS,
                "random": [0, 0, 0],
                "eval_every": 100,
                "eval_episodes": 1,
            }
        )
    )
    for seed in seeds:
        for method, rows in (("finetune", RETURNS + shift * seed), ("reference", None)):
            out = folder / method / f"seed_{seed}"
            out.mkdir(parents=True, exist_ok=True)
            lines = ["step,task,episodes,mean_return"]
            if rows is None:
                lines += [
                    f"{s},{i},1,{v}" for i in range(3) for s, v in zip((0, 50, 100), REFERENCE[i])
                ]
            else:
                lines += [
                    f"{int(s)},{i},1,{rows[b, i]}" for b, s in enumerate(STEPS) for i in range(3)
                ]
            (out / "evaluations.csv").write_text("\n".join(lines) + "\n")
    return folder


def test_the_report_reads_a_run_folder_and_agrees_with_the_hand_computation(tmp_path):
    summary = summarise(load_run(write_run(tmp_path / "run")))
    agg = summary["methods"]["finetune"]["aggregate"]
    assert agg["average"] == pytest.approx((0.5, 0.5, 0.5))  # two equal seeds: no width
    assert agg["forgetting"][0] == pytest.approx(0.6)  # (0.8 + 0.4) / 2
    assert agg["backward_transfer"][0] == pytest.approx(-0.6)
    assert summary["reference_final_return"] == [10.0, 10.0, 10.0]


def test_the_command_prints_the_table_and_writes_json_and_the_matrix(tmp_path, capsys):
    run = write_run(tmp_path / "run", seeds=(0, 1, 2), shift=0.5)
    assert main(["lifelong", "report", str(run), "--out", str(tmp_path / "out")]) == 0
    text = capsys.readouterr().out
    assert "finetune (3)" in text and "forgetting" in text and "[" in text
    data = json.loads((tmp_path / "out" / "lifelong.json").read_text())
    assert len(data["methods"]["finetune"]["seeds"]) == 3
    assert (tmp_path / "out" / "lifelong.png").stat().st_size > 5000


@pytest.mark.parametrize(
    "damage, words",
    [
        (
            lambda t: t.replace("step,task,episodes,mean_return", "step,task,return"),
            ":1: expected the columns",
        ),
        (lambda t: t.replace("\n100,1,1,2.0\n", "\n100,1,1,many\n"), ":6: expected step,task"),
        (lambda t: t.replace("\n100,1,1,2.0\n", "\n100,7,1,2.0\n"), ":6: task 7 of 3"),
        (
            lambda t: t.replace("\n100,1,1,2.0\n", "\n100,0,1,2.0\n"),
            "block 1 does not evaluate every task",
        ),
    ],
)
def test_bad_evaluation_files_are_refused_with_file_and_line(tmp_path, damage, words):
    run = write_run(tmp_path / "run", seeds=(0,))
    path = run / "finetune" / "seed_0" / "evaluations.csv"
    path.write_text(damage(path.read_text()))
    with pytest.raises(RunError, match=words.replace("[", r"\[")) as caught:
        load_run(run)
    assert str(path) in str(caught.value)
    assert main(["lifelong", "report", str(run), "--no-plot"]) == 2


def test_the_scale_falls_back_to_the_best_learner_where_the_reference_learnt_nothing(tmp_path):
    folder = write_run(tmp_path / "run", seeds=(0,))
    # The reference ends at random play (0) on task 2: the best any learner reached there
    # (the fine-tuner's 9 at the last block) becomes the level.
    csv = folder / "reference" / "seed_0" / "evaluations.csv"
    rows = csv.read_text().splitlines()
    csv.write_text(
        "\n".join([r if not r.startswith("100,2,") else "100,2,1,0" for r in rows]) + "\n"
    )
    summary = summarise(load_run(folder))
    assert summary["reference_final_return"] == [10.0, 10.0, 9.0]
    # A task that no learner ever beats random play on gets random + 1, never a zero scale.
    for name in ("finetune", "reference"):
        path = folder / name / "seed_0" / "evaluations.csv"
        lines = path.read_text().splitlines()
        path.write_text(
            "\n".join(
                [lines[0]]
                + [
                    ln if ln.split(",")[1] != "2" else ln.rsplit(",", 1)[0] + ",-1"
                    for ln in lines[1:]
                ]
            )
            + "\n"
        )
    assert summarise(load_run(folder))["reference_final_return"][2] == 1.0
