"""``baselines.benchmark.reach``: where in an episode a task first pays, by play."""

from __future__ import annotations

from baselines.benchmark.reach import Reach, reach, table


def test_a_terminal_goal_pays_on_the_episodes_last_step():
    # switch_door's goal ends the episode: the solver's first payment is its last step,
    # within the step limit, and the share of the limit is that step over it.
    played = reach("switch_door", "scripted", [100000])
    assert played.paid == 1 and played.limit == 500
    assert played.first_steps == played.lengths
    assert 0 < played.first_steps[0] < played.limit
    assert played.median_share == played.first_steps[0] / played.limit
    assert played.scores[0] >= 10


def test_the_table_says_how_often_and_how_early_each_method_is_paid():
    never = Reach(4, 0, [None] * 4, [500] * 4, [0.0] * 4, 500)
    early = Reach(4, 3, [50, None, 100, 150], [500] * 4, [10.0] * 4, 500)
    assert never.median_first is None and early.median_first == 100
    row = table({"task": {"random": vars(never), "scripted": vars(early)}}).splitlines()[-1]
    assert row == "| `task` | 500 | 0 of 4 | - | 3 of 4 | step 100 (20% of it) |"


def test_the_benchmark_page_names_the_tasks_random_play_is_never_paid_in():
    from baselines.benchmark.page import reach_section

    never = vars(Reach(2, 0, [None, None], [500, 500], [0.0, 0.0], 500))
    paid = vars(Reach(2, 1, [40, None], [40, 500], [10.0, 0.0], 500))
    lines = reach_section(
        {"hard": {"random": never, "scripted": paid}, "easy": {"random": paid, "scripted": paid}}
    )
    assert lines[0] == "## Where the reward lies"
    assert "Random play is never paid in 1 of 2 scenarios: `hard`." in lines
    assert (
        "| `easy` | 500 | 1 of 2 | step 40 (8% of it) | 1 of 2 | step 40 (8% of it) |"
        in "\n".join(lines)
    )
