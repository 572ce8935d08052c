"""The benchmark page's section on the imitation probe (``baselines.benchmark.imitate``):
for each task probed, the scripted solver's score, PPO's at the standard budget and the
imitator's, all normalised, and what they say together. Read from
``results/imitation.json``, one entry per scenario (``imitate --record``)."""

from __future__ import annotations

import json
from pathlib import Path

from baselines.benchmark.records import OUT, task_versions
from baselines.benchmark.tables import figure_text, markdown_table

IMITATION = OUT.parent / "imitation.json"
HALF = 0.5


def read_imitation(path: Path = IMITATION) -> dict | None:
    """Each probed scenario's record, if any were made."""
    return json.loads(path.read_text(encoding="utf-8")) if path.exists() else None


def reading(imitator: float, ppo: float | None, started: float | None = None) -> str:
    """What the normalised scores of the imitator, of PPO from scratch and of PPO started
    from the imitator (if run) say together."""
    if started is not None and started >= HALF and (ppo is None or ppo < HALF):
        return "PPO keeps the way once shown it: from scratch it stays below half"
    if started is not None and started < imitator - 0.1:
        return "shown but not held: PPO from the imitator loses what it does"
    if imitator >= HALF:
        if ppo is not None and ppo < HALF:
            return "seen enough: PPO does not find what the imitator learns"
        return "seen enough"
    if ppo is not None and ppo >= HALF:
        return "learnt from the reward, though not imitated from the solver's labels"
    return "not imitated: one observation does not show the solver's way"


def table_row(name: str, record: dict, row: dict | None) -> list[str]:
    """One probed task's cells; ``row``: its row of the standard tier (None if absent)."""
    ours = None if row is None else row["normalised"]
    ppo_iqm = None if ours is None else ours["iqm"]
    scripted = None if row is None or row["scripted"] is None else row["scripted"]["iqm"]
    steps = record["rounds"][-1]["steps_kept"]
    then = record.get("then_ppo")
    started = None if then is None else then["normalised"]
    return [
        f"`{name}`",
        "-" if scripted is None else f"{scripted:.3g}",
        figure_text(ours) or "-",
        f"{record['held_out']:.3g} ({record['normalised']:.3g})",
        "-" if then is None else f"{then['held_out']:.3g} ({started:.3g})",
        f"{len(record['rounds']) - 1} rounds, {steps:,} steps"
        + ("" if then is None else f"; PPO {then['agent_steps']:,} agent-steps"),
        f"{record['cpu_seconds'] / 60:.1f} min",
        reading(record["normalised"], ppo_iqm, started),
    ]


def imitation_section(records: dict, rows: list[dict]) -> list[str]:
    """The section: one row per probed scenario of its current version; ``rows``: the
    standard tier's rows (PPO's figures), by task."""
    by_task = {r["task"]: r for r in rows}
    current, stale = [], []
    for name in sorted(records):
        record = records[name]
        if {name: record["version"]} != task_versions(name, "scenario"):
            stale.append(name)
            continue
        current.append(table_row(name, record, by_task.get(name)))
    lines = [
        "## Within reach of what the agent sees",
        "",
        "The imitation probe: `baselines.ppo`'s network, feed-forward, taught the scripted "
        "solver's action at every step from the agent's own observations (DAgger: the "
        "solver plays the first round, the network the others, the solver's actions the "
        "labels), then scored on the held-out episodes; normalised as PPO's. An imitator "
        "at half the solver's score or above shows that what the agent sees is enough for a "
        "policy that reads one observation, so PPO's shortfall there is one of finding or "
        "crediting the reward; an imitator far below says the solver knows what the agent "
        "does not see or remember. PPO from the imitator: `baselines.ppo` started from the "
        "imitator's weights in the task's standard configuration (its curriculum left "
        "out); where it holds the way and PPO from scratch does not, what blocks the task "
        "is finding the reward, not reading or crediting it. These runs use the solver's "
        "demonstrations and are not the benchmark's PPO, whose figures above learn from "
        "the reward alone. One seed a task, scored on the ten held-out episodes: a "
        "reading to follow up, not a verdict (docs/results.md gives the runs' curves and "
        "their scores on other episodes). `python -m baselines.benchmark.imitate --scenario S "
        "--ppo-steps 1000000 --record` (results in `results/imitation.json`; CPU: both "
        "parts).",
        "",
        *markdown_table(
            ["Task", "Scripted", "PPO, standard (normalised)", "Imitator (normalised)"]
            + ["PPO from the imitator", "Taught on", "CPU", "Reading"],
            current,
        ),
        "",
    ]
    if stale:
        names = ", ".join(f"`{n}`" for n in stale)
        lines += [f"Probed on an older version of the task, not shown: {names}.", ""]
    return lines
