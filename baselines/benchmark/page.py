"""The benchmark's page, docs/benchmark.md, as Markdown from the figures
``baselines.benchmark.summary`` builds: how it is measured, the tiers, random, scripted
and open-loop play, a section per tier of PPO, the levels and the provenance."""

from __future__ import annotations

import json

from baselines.benchmark.levels import render_levels
from baselines.benchmark.reach import table as reach_table
from baselines.benchmark.summary import VERDICTS
from baselines.benchmark.tables import (
    ablation_table,
    figure_text,
    markdown_table,
    reference_table,
    runs_table,
    table,
)
from baselines.benchmark.within_reach import imitation_section


def planned_text(tier: dict) -> str:
    text = (
        f"The whole tier is {tier['planned_steps'] / 1e6:.3g}M agent-steps of PPO training "
        "(every budget times the seeds)"
    )
    hours = tier.get("planned_hours")
    if not hours:
        return text + "."
    return (
        text + f": about {hours['whole']:.1f} CPU-hours, {hours['left']:.1f} of them still to "
        "run, each task at the rate of its committed PPO seeds (agent-steps per CPU-second of "
        "training and scoring) in this tier, else in the others, else the tier's pooled rate."
    )


TIER_TEXT = {
    "smoke": "regressions only: a short run of every task (the results without a tier)",
    "standard": "the published budgets' order of magnitude, every task, each in the best "
    "shipped configuration known for it",
    "certificate": "ten times the standard budget, for the tasks still open at it (the "
    "settings file lists them)",
}


def figure_path(tier: str) -> str:
    """A tier's figure, relative to docs/ (smoke's keeps the page's first name)."""
    return "images/benchmark.png" if tier == "smoke" else f"images/benchmark_{tier}.png"


def open_at_standard(summary: dict) -> list[str]:
    """Tasks below half the scripted score at the standard budget that the certificate
    tier does not run."""
    tiers = summary["tiers"]
    if "standard" not in tiers or "certificate" not in tiers:
        return []
    only = tiers["certificate"]["only"]
    return [
        r["task"]
        for r in tiers["standard"]["rows"]
        if r["normalised"] is not None
        and r["normalised"]["iqm"] < 0.5
        and only is not None
        and r["task"] not in only
    ]


def tier_section(tier: dict, summary: dict) -> list[str]:
    """One tier's section: its figures, its tables, what is missing and its runs."""
    return [
        *tier_figures(tier),
        *tier_tables(tier),
        *tier_ablations(tier),
        *tier_gaps(tier, summary),
        *tier_runs(tier),
        "",
    ]


def tier_figures(tier: dict) -> list[str]:
    """A tier's heading, aggregate, verdicts, PPO against open-loop play, CPU time and figure."""
    rows = tier["rows"]
    agg = tier["aggregate"]
    name = tier["tier"]
    counts = {v: sum(r["verdict"] == v for r in rows) for v in VERDICTS}
    compared = [r for r in rows if r["beats_open_loop"]]
    lines = [
        f"## {name.capitalize()}: {tier['budget']:,} agent-steps x {tier['seeds']} seeds",
        "",
        f"The {name} tier: {TIER_TEXT[name]}. `make benchmark TIER={name}` runs it.",
        "",
    ]
    if agg is not None:
        lines.append(
            f"Aggregate normalised IQM of PPO over the {agg['tasks']} task"
            + ("s" if agg["tasks"] != 1 else "")
            + f" it was run on: **{agg['iqm']:.3g}** "
            f"(95% interval {agg['low']:.3g} to {agg['high']:.3g}); {tier['half']} at 0.5 "
            "or above."
        )
    else:
        lines.append("PPO has not been run on any task of this tier yet.")
    lines += ["", "Verdicts: " + ", ".join(f"{n} {v}" for v, n in counts.items()) + "."]
    if compared:
        beaten = [r["task"] for r in compared if r["beats_open_loop"] != "yes"]
        lines += [
            "",
            f"PPO beats open-loop play on {len(compared) - len(beaten)} of the "
            f"{len(compared)} tasks where both have run"
            + ("; not shown on " + ", ".join(f"`{t}`" for t in beaten) + "." if beaten else "."),
        ]
    lines += [
        "",
        f"PPO's CPU time in this tier: {tier['ppo_seconds'] / 3600:.2f} CPU-hours (training "
        "and scoring, summed over seeds). " + planned_text(tier),
        "",
    ]
    if agg is not None:
        lines += [
            f"```{{image}} {figure_path(name)}",
            f":alt: PPO's normalised score per task in the {name} tier, IQM over seeds with "
            "95% intervals",
            ":width: 640px",
            "```",
            "",
        ]
    return lines


def tier_tables(tier: dict) -> list[str]:
    """A tier's PPO figures, scenarios then streams."""
    lines = []
    name = tier["tier"]
    for kind, title in (("scenario", "Scenarios"), ("stream", "Streams")):
        shown = [r for r in tier["rows"] if r["kind"] == kind and (r["learner"] or r["ppo"])]
        lines += [f"### {title} ({name})", ""]
        lines += table(shown, tier["seeds"]) if shown else [f"No {kind} in this tier."]
        lines.append("")
    return lines


def tier_ablations(tier: dict) -> list[str]:
    """PPO against its own configuration without the channel, where a task has one."""
    shown = [r for r in tier["rows"] if r["no_channel_learner"] or r["ppo_no_channel"]]
    if not shown:
        return []
    return [
        f"### Without the channel ({tier['tier']})",
        "",
        "PPO in the same configuration, trained and scored without the scenario's channel "
        "(`baselines.ppo --no-channel`): PPO has learnt to use the channel where its "
        "interval lies above this one's (raw scores; **no** where it lies below, **not "
        "shown** where they overlap).",
        "",
        *ablation_table(shown, tier["seeds"]),
        "",
    ]


def tier_gaps(tier: dict, summary: dict) -> list[str]:
    """The tasks a tier has not run yet, or not every seed of, and (the certificate's) the
    tasks open at the standard budget that it does not run."""
    rows = tier["rows"]
    name = tier["tier"]
    missing = [r["task"] for r in rows if r["learner"] and r["ppo"] is None]
    partial = [
        r["task"] for r in rows if r["ppo"] is not None and r["ppo"]["seeds"] < tier["seeds"]
    ]
    lines = [f"### Not yet run ({name})", ""]
    if missing:
        lines.append(
            f"PPO has no committed result of this tier on these tasks yet; `make benchmark "
            f"TIER={name}` runs them: " + ", ".join(f"`{m}`" for m in missing) + "."
        )
    else:
        lines.append("Every task of this tier has its PPO results.")
    if partial:
        lines += [
            "",
            f"PPO has fewer than {tier['seeds']} seeds on "
            + ", ".join(f"`{m}`" for m in partial)
            + f"; `make benchmark TIER={name}` runs the rest.",
        ]
    if name == "certificate":
        stray = open_at_standard(summary)
        lines += [
            "",
            "Tasks below 0.5 at the standard budget that this tier does not run yet: "
            + (", ".join(f"`{t}`" for t in stray) + "." if stray else "none."),
        ]
    return lines


def tier_runs(tier: dict) -> list[str]:
    """Every PPO seed of a tier, if it has any."""
    if not any(r["runs"] for r in tier["rows"]):
        return []
    return [
        "",
        f"### Runs ({tier['tier']})",
        "",
        "Each PPO seed: its CPU time, the machine's load average before and after it, "
        "and the calibration timed at its start (256 x 256 matrix products per "
        "CPU-second of one thread: a faster machine does more).",
        "",
        *runs_table(tier["rows"]),
    ]


def render(summary: dict) -> str:
    """The whole page, docs/benchmark.md."""
    lines = [*page_head(), *measured_text(summary), *tiers_text(summary)]
    for tier in summary["tiers"].values():
        lines += tier_section(tier, summary)
    if summary.get("levels") is not None:
        lines += [*render_levels(summary["levels"]), ""]
    if summary.get("reach"):
        lines += reach_section(summary["reach"])
    if summary.get("imitation") and "standard" in summary["tiers"]:
        lines += imitation_section(summary["imitation"], summary["tiers"]["standard"]["rows"])
    return "\n".join([*lines, *provenance(summary)])


def reach_section(results: dict) -> list[str]:
    """Where each task first pays within an episode, by play (``baselines.benchmark.reach``)."""
    blocked = sorted(n for n, r in results.items() if r["random"]["paid"] == 0)
    return [
        "## Where the reward lies",
        "",
        "Before any training: how often random play and the scripted solver are paid at "
        "all in the held-out episodes, and the median step of the first payment (with its "
        "share of the step limit). Where random play is never paid, a learner starting from "
        "it must find the reward by exploring before it can learn anything: some do (PPO "
        "solves `key_door` at 1M agent-steps), so this says where exploration has to work, "
        "not that it fails. `python -m baselines.benchmark.reach` (results in "
        "`results/reach.json`).",
        "",
        reach_table(results),
        "",
        f"Random play is never paid in {len(blocked)} of {len(results)} scenarios: "
        + ", ".join(f"`{n}`" for n in blocked)
        + ".",
        "",
    ]


def page_head() -> list[str]:
    """The title and what the page is made from."""
    return [
        "# Benchmark",
        "",
        "Random play, open-loop play, each task's scripted reference solver and "
        "shared-parameter PPO on every shipped scenario and task stream, PPO in tiers of "
        "budget. Written by `make benchmark-table` from the per-seed JSON files under "
        "`results/benchmark/` (no training); `make benchmark TIER=smoke|standard|certificate` "
        "runs what is missing and resumes where it stopped (`baselines/benchmark/`, "
        "settings in `baselines/benchmark/settings.yaml`).",
        "",
    ]


def measured_text(summary: dict) -> list[str]:
    """How it is measured: the methods, tiers, figures, verdicts and curves."""
    tiers = summary["tiers"]
    search = summary["open_loop"]
    return [
        "## How it is measured",
        "",
        f"- Random, scripted and open-loop play run {summary['seeds']} seeds on each task, and "
        "serve every tier (a scripted solver that draws no random numbers, `greedy`, "
        "`planner` or `carrier`, runs one: its seeds play alike); PPO runs its tier's seeds. "
        f"Every seed is scored on the same {summary['episodes']} held-out episodes (a "
        "scenario: reset with seeds 100000 on; a stream: each task's, seeded as "
        "`baselines.lifelong` seeds its evaluation blocks). A scenario's score is the mean "
        "return per agent its reference counts (with `carrier_vs_random`, the first team's "
        "against random play); a stream's is the mean over its tasks (the never-ending "
        "stream: its first 1000 steps).",
        "- Open-loop play (`baselines/open_loop.py`): actions by the time step alone, never "
        f"by what the agent sees. Per seed, {search['candidates']} schedules are drawn (each "
        f"action uniform, held for 1 to {search['hold']} steps; each agent its own); the one "
        f"with the best mean over {search['episodes']} training episodes (seeded apart from "
        "the held-out ones) is kept and scored on the held-out episodes. PPO that does not "
        "beat it has learnt nothing a fixed schedule of moves could not do.",
        "- PPO: `baselines.ppo` (one network shared by every agent, on the batched env) for "
        "the budget of agent-steps the table states, in the configuration it names (options "
        "in the settings file; the learner's defaults otherwise), then its final checkpoint "
        "is scored; through a stream of tasks, `baselines.lifelong --method finetune` over "
        "the stream's life scaled to the budget, scored by its last evaluation block; "
        "through the never-ending stream, the same learner for the budget "
        "(`baselines/never_ending.py`), its checkpoint then scored as the other methods are.",
        "- The channel's ablation (`ppo_no_channel`, on the scenarios with a channel): PPO in "
        "the task's configuration of the tier, trained and scored without the channel "
        "(`baselines.ppo --no-channel`), the same seeds; PPO has learnt to use the channel "
        "where its interval lies above the ablation's.",
        "- Tiers: " + "; ".join(f"**{t}**: {TIER_TEXT[t]}" for t in tiers) + ".",
        "- Figures: interquartile mean over seeds (95% stratified bootstrap interval). "
        "Normalised: random play 0, scripted play 1 (the means of their seeds). PPO beats "
        "open-loop play when its interval lies above open-loop play's (raw scores); **no** "
        "when it lies below, **not shown** when they overlap.",
        "- Verdicts: " + "; ".join(f"**{name}**: {text}" for name, text in VERDICTS.items()) + ".",
        "- Learning curves (each scenario's page): the training return at 50 checkpoints of "
        "each seed, IQM over seeds with its 95% interval, random, scripted and open-loop "
        "play's held-out scores as lines (`baselines/benchmark/curves.py`; "
        "`docs/images/curves/`).",
        "",
    ]


def listed_with_results(rows: list[dict]) -> str:
    """How many of a tier's listed tasks (``learner``) have PPO results, of how many: a
    task run at the tier before it left the list is not one of them."""
    done = sum(r["ppo"] is not None and r["learner"] for r in rows)
    return f"{done} of {sum(r['learner'] for r in rows)}"


def tiers_text(summary: dict) -> list[str]:
    """The tiers side by side, the reference methods' CPU time, and their table."""
    tiers = summary["tiers"]
    cpu = summary["cpu_seconds"]
    return [
        "## Tiers",
        "",
        *markdown_table(
            ["Tier", "Budget", "Seeds", "Tasks with PPO results", "Aggregate normalised IQM"]
            + ["At 0.5 or above", "PPO CPU-hours"],
            [
                [
                    t["tier"],
                    f"{t['budget']:,}",
                    str(t["seeds"]),
                    listed_with_results(t["rows"]),
                    figure_text(t["aggregate"]) or "-",
                    str(t["half"]),
                    f"{t['ppo_seconds'] / 3600:.2f}",
                ]
                for t in tiers.values()
            ],
        ),
        "",
        f"CPU time of random, scripted and open-loop play: random {cpu['random']:.0f} s, "
        f"scripted {cpu['scripted']:.0f} s, open-loop {cpu['open_loop']:.0f} s (summed over "
        "seeds).",
        "",
        "## Random, scripted and open-loop play",
        "",
        *reference_table(tiers["smoke"]["rows"]),
        "",
    ]


def provenance(summary: dict) -> list[str]:
    """The commits and package versions the results were made with."""
    return [
        "## Provenance",
        "",
        "Commits the results were run at: " + ", ".join(f"`{c}`" for c in summary["commits"]),
        "",
        "Versions: "
        + "; ".join(
            ", ".join(f"{k} {v}" for k, v in json.loads(v).items()) for v in summary["versions"]
        ),
        "",
        "Each JSON file also holds the machine's load before and after its run and, from "
        "the tiers on, the calibration timed at its start.",
        "",
    ]
