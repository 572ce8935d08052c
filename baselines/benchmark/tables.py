"""The benchmark page's Markdown tables and their cells: random, scripted and open-loop
play per task, a tier's PPO figures per task, and a tier's PPO seeds."""

from __future__ import annotations


def figure_text(x: dict | None) -> str:
    if x is None:
        return ""
    iqm, low, high = (0.0 if abs(x[k]) < 1e-12 else x[k] for k in ("iqm", "low", "high"))
    return f"{iqm:.3g} ({low:.3g} to {high:.3g})"


def ppo_cell(row: dict, seeds: int) -> str:
    if row["ppo"] is not None:
        done = row["ppo"]["seeds"]
        return figure_text(row["ppo"]) + (f", {done} of {seeds} seeds" if done < seeds else "")
    return "not yet run" if row["learner"] else "not in this tier"


def normalised_cell(row: dict, key: str = "normalised") -> str:
    if row[key] is not None:
        return figure_text(row[key])
    if row["scale"] is not None and not row["scale"]["ok"]:
        return "no scale: scripted does not beat random"
    return ""


def open_loop_cell(row: dict) -> str:
    answer = row["beats_open_loop"]
    return answer if answer in ("", "yes") else f"**{answer}**"


def solver_text(name: str, kind: str) -> str:
    if kind == "stream":
        return "each task's reference"
    from flatland_ma.scenario.loader import load_scenario

    reference = load_scenario(name).reference
    if reference is None:
        return ""
    if reference.teams:
        return f"{reference.solver}: {', '.join(reference.teams)}"
    return reference.solver


def markdown_table(headers: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    return out + ["| " + " | ".join(cells) + " |" for cells in rows]


def reference_table(rows: list[dict]) -> list[str]:
    """Random, scripted and open-loop play (the same in every tier)."""
    headers = ["Task", "Random", "Scripted", "Reference solver", "Open-loop"]
    headers += ["Open-loop, normalised"]
    return markdown_table(
        headers,
        [
            [
                f"`{r['task']}`",
                figure_text(r["random"]) or "not yet run",
                figure_text(r["scripted"]) or "not yet run",
                solver_text(r["task"], r["kind"]),
                figure_text(r["open_loop"]) or "not yet run",
                normalised_cell(r, "open_loop_normalised"),
            ]
            for r in rows
        ],
    )


def table(rows: list[dict], seeds: int) -> list[str]:
    """One tier's PPO figures per task."""
    headers = ["Task", "PPO", "PPO, normalised", "Beats open-loop", "Configuration"]
    headers += ["Budget", "CPU per seed", "Verdict"]
    out = []
    for r in rows:
        budget = f"{r['budget']:,}" if r["learner"] or r["ppo"] else "-"
        cpu = f"{r['cpu_seconds'] / len(r['runs']) / 60:.1f} min" if r["runs"] else ""
        out.append(
            [
                f"`{r['task']}`",
                ppo_cell(r, seeds),
                normalised_cell(r),
                open_loop_cell(r),
                r["configuration"] if r["learner"] or r["ppo"] else "-",
                budget,
                cpu,
                r["verdict"],
            ]
        )
    return markdown_table(headers, out)


def ablation_table(rows: list[dict], seeds: int) -> list[str]:
    """PPO with and without the channel, on a tier's tasks that have one."""
    headers = ["Task", "PPO", "PPO without the channel", "The channel helps"]
    headers += ["Configuration without it", "CPU per seed"]
    out = []
    for r in rows:
        ablated = r["ppo_no_channel"]
        done = ablated["seeds"] if ablated else 0
        cpu = r["no_channel_cpu_seconds"]
        out.append(
            [
                f"`{r['task']}`",
                ppo_cell(r, seeds),
                figure_text(ablated) + (f", {done} of {seeds} seeds" if done < seeds else "")
                if ablated
                else "not yet run",
                open_loop_cell({"beats_open_loop": r["channel_helps"]}),
                r["no_channel_configuration"],
                f"{sum(cpu) / len(cpu) / 60:.1f} min" if cpu else "",
            ]
        )
    return markdown_table(headers, out)


def runs_table(rows: list[dict]) -> list[str]:
    """Every PPO seed of a tier: its cost, the machine's load and calibration."""
    out = []
    for r in rows:
        for run in r["runs"]:
            load = " to ".join("-" if x is None else f"{x:g}" for x in run["load"])
            calibration = run["calibration"]
            out.append(
                [
                    f"`{r['task']}`",
                    str(run["seed"]),
                    f"{run['agent_steps']:,}",
                    f"{run['cpu_seconds']:.0f}",
                    "-" if run["wall_seconds"] is None else f"{run['wall_seconds']:.0f}",
                    load,
                    "not recorded" if calibration is None else f"{calibration:.0f}",
                    f"`{run['commit']}`",
                ]
            )
    headers = ["Task", "Seed", "Agent-steps", "CPU s", "Wall s", "Load (1 min)"]
    headers += ["Calibration (matmuls/CPU-s)", "Commit"]
    return markdown_table(headers, out)
