"""The paper's figure and a results table from the runs' CSVs.

    python -m baselines.benchmark.plot runs/dqn/fruits_poisons runs/a3c/fruits_poisons \\
        runs/dfp/fruits_poisons --references 20 --out docs/images/results_fruits_poisons.png

Each RUNS argument is a directory of ``seed_*.csv`` (one algorithm on one scenario). Per
seed, an episode's return is the mean over its agents. The figure shows, per algorithm,
the mean over seeds of the return per episode (after a trailing moving average of
``--smooth`` episodes within each seed) with a 95% t-interval band, over the episodes
every seed completed. The table (Markdown, printed) gives per algorithm:

- final return: per seed the mean return of the last ``--final`` fraction of its
  episodes, then the mean over seeds +- the 95% t-interval half-width;
- the counts per episode (final): the mean over seeds of the same final means of each
  counter column of the CSVs but the score (the return again): ``fruits / poisons`` on
  fruits_poisons, ``key / goal`` on key_door;
- steps to 80% of final: the first episode from which the smoothed mean curve stays at or
  above 80% of the final return, as the mean over seeds of the steps done by then;
- evaluation after training: per seed the mean return of the episodes its final network
  played after training at ``--eval-epsilon`` (DQN and DFP store them in their JSON), then
  the mean over seeds +- 95% t-interval; it names how many seeds have it when not all do;
- wall time per seed (mean +- standard deviation) and the share of it spent in the
  environment (from the JSON files).

``--references N`` also plays N episodes of the scripted greedy policy and of uniform
random actions on the same scenario, draws them as lines and adds them to the table.
"""

from __future__ import annotations

import argparse
import csv
import json
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from baselines.common import FIXED_COLUMNS, info_counters


@dataclass
class Run:
    seed: int
    steps: np.ndarray
    """Per episode, the agent-steps done when it ended."""
    returns: np.ndarray
    """Per episode, the mean over agents of their returns."""
    counters: dict[str, np.ndarray]
    """Per counter column of the CSV (``score``, ``fruits``, ``poisons`` on fruits_poisons;
    logs written before the counters came from the scenario have no ``score``), per
    episode the mean over agents."""
    agent_returns: dict[str, np.ndarray]
    """Per agent, its return in each episode."""
    summary: dict
    """The run's JSON summary (arguments, wall time, env share), if written."""


def load_runs(directory: Path) -> list[Run]:
    runs = []
    for path in sorted(directory.glob("seed_*.csv"), key=lambda p: int(p.stem.split("_")[1])):
        by_episode = defaultdict(list)
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            counters = [c for c in reader.fieldnames or [] if c not in FIXED_COLUMNS]
            for row in reader:
                by_episode[int(row["episode"])].append(row)
        episodes = [by_episode[k] for k in sorted(by_episode)]
        agents = sorted({row["agent"] for rows in episodes for row in rows})

        def per_episode(column, rows_of=episodes):
            return np.array([np.mean([float(r[column]) for r in rows]) for rows in rows_of])

        summary_path = path.with_suffix(".json")
        runs.append(
            Run(
                seed=int(path.stem.split("_")[1]),
                steps=per_episode("step"),
                returns=per_episode("return"),
                counters={name: per_episode(name) for name in counters},
                agent_returns={
                    a: np.array(
                        [float(r["return"]) for rows in episodes for r in rows if r["agent"] == a]
                    )
                    for a in agents
                },
                summary=json.loads(summary_path.read_text()) if summary_path.exists() else {},
            )
        )
    return runs


def smooth(x: np.ndarray, window: int) -> np.ndarray:
    """Trailing moving average; the first values average what is there so far."""
    sums = np.cumsum(np.insert(np.asarray(x, np.float64), 0, 0.0))
    index = np.arange(1, len(x) + 1)
    return (sums[index] - sums[np.maximum(0, index - window)]) / np.minimum(index, window)


def t_interval(samples: np.ndarray, axis: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Mean and the half-width of its 95% t-interval along ``axis`` (0 if one sample)."""
    samples = np.asarray(samples, np.float64)
    n = samples.shape[axis]
    mean = samples.mean(axis)
    if n < 2:
        return mean, np.zeros_like(mean)
    sem = samples.std(axis, ddof=1) / np.sqrt(n)
    return mean, stats.t.ppf(0.975, n - 1) * sem


def curve(runs: list[Run], window: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Episodes 1..n (n completed by every seed), mean smoothed return, CI half-width."""
    n = min(len(run.returns) for run in runs)
    matrix = np.stack([smooth(run.returns, window)[:n] for run in runs])
    mean, half = t_interval(matrix)
    return np.arange(1, n + 1), mean, half


def summarise(
    label: str, runs: list[Run], window: int, final: float, eval_epsilon: float = 0.05
) -> dict:
    def last_part(values: np.ndarray) -> float:
        return values[-max(1, int(len(values) * final)) :].mean()

    finals = np.array([last_part(r.returns) for r in runs])
    # The counters every seed logged: a directory resumed with a newer version of the
    # baselines mixes logs with a score column and logs without.
    names = [n for n in runs[0].counters if all(n in r.counters for r in runs)]
    counters = {n: float(np.mean([last_part(r.counters[n]) for r in runs])) for n in names}
    final_mean, final_half = t_interval(finals)
    episodes, mean, _ = curve(runs, window)
    to_80 = None
    if final_mean > 0:
        # From the first episode after which the mean curve never falls below 80% again
        # (a noisy flat curve may touch 80% early by chance; it does not stay there).
        below = np.flatnonzero(mean < 0.8 * final_mean)
        first = below[-1] + 1 if len(below) else 0
        if first < len(mean):
            to_80 = np.mean([r.steps[first] for r in runs])
    evaluations = [
        r.summary["evaluation"]["return"]
        for r in runs
        if "evaluation" in r.summary and r.summary["evaluation"].get("epsilon", 0.0) == eval_epsilon
    ]
    walls = [r.summary["wall_seconds"] for r in runs if "wall_seconds" in r.summary]
    shares = [r.summary["env_share"] for r in runs if "env_share" in r.summary]
    return {
        "label": label,
        "seeds": len(runs),
        "steps": int(np.median([r.summary.get("steps", r.steps[-1]) for r in runs])),
        "episodes": int(np.median([len(r.returns) for r in runs])),
        "final": (float(final_mean), float(final_half)),
        "counters": counters,
        "steps_to_80": to_80,
        "evaluation": (*map(float, t_interval(np.array(evaluations))), len(evaluations))
        if evaluations
        else None,
        "wall_minutes": (np.mean(walls) / 60, np.std(walls) / 60) if walls else None,
        "env_share": float(np.mean(shares)) if shares else None,
    }


def references(scenario: str, episodes: int) -> list[dict]:
    """The scripted greedy policy and uniform random actions, ``episodes`` episodes each."""
    import flatland_ma
    from flatland_ma.policies import GreedyForager, RandomPolicy, evaluate

    rows = []
    for label, make in (
        ("scripted greedy", lambda env: lambda agent: GreedyForager(env.spec)),
        ("uniform random", lambda env: lambda agent: RandomPolicy(env.action_space(agent), seed=0)),
    ):
        env = flatland_ma.parallel_env(scenario)
        scores = evaluate(env, make(env), episodes=episodes, seed=10_000)
        mean, half = t_interval(np.array(scores.returns))
        names = info_counters(next(iter(scores.infos[0].values())))
        counters = {
            name: float(
                np.mean([np.mean([i[name] for i in infos.values()]) for infos in scores.infos])
            )
            for name in names
        }
        rows.append(
            {
                "label": label,
                "episodes": episodes,
                "final": (float(mean), float(half)),
                "counters": counters,
            }
        )
    return rows


def thousands(steps: float) -> str:
    """Steps to three significant figures: 500 -> 0.5k, 999424 -> 999k, 2e6 -> 2M."""
    return f"{steps / 1e6:.3g}M" if steps >= 999_500 else f"{steps / 1e3:.3g}k"


def table(rows: list[dict], reference_rows: list[dict]) -> str:
    names = list(dict.fromkeys(n for r in rows + reference_rows for n in r["counters"]))
    names = [n for n in names if n != "score"]  # the return again

    def counts(r: dict) -> str:
        cells = [f"{r['counters'][n]:.1f}" if n in r["counters"] else "-" for n in names]
        return " / ".join(cells) or "-"

    lines = [
        "| algorithm | seeds x steps (episodes) | final return (mean ± 95% CI) | "
        f"{' / '.join(names) or 'counts'} per episode (final) | steps to 80% of final | "
        "evaluation after training (mean ± 95% CI) | wall time per seed (mean ± std) | "
        "env share |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        to_80 = f"{r['steps_to_80'] / 1000:.0f}k" if r["steps_to_80"] is not None else "not reached"
        wall = "{:.1f} ± {:.1f} min".format(*r["wall_minutes"]) if r["wall_minutes"] else "-"
        share = f"{r['env_share']:.1%}" if r["env_share"] is not None else "-"
        evaluation = "-"
        if r["evaluation"]:
            mean, half, n = r["evaluation"]
            evaluation = f"{mean:.1f} ± {half:.1f}" + (
                f" ({n} of {r['seeds']} seeds)" if n < r["seeds"] else ""
            )
        lines.append(
            f"| {r['label']} | {r['seeds']} x {thousands(r['steps'])} ({r['episodes']}) | "
            f"{r['final'][0]:.1f} ± {r['final'][1]:.1f} | {counts(r)} | "
            f"{to_80} | {evaluation} | {wall} | {share} |"
        )
    for r in reference_rows:
        lines.append(
            f"| {r['label']} (no learning) | {r['episodes']} episodes | "
            f"{r['final'][0]:.1f} ± {r['final'][1]:.1f} | {counts(r)} | - | - | - | - |"
        )
    return "\n".join(lines)


def parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("runs", nargs="+", type=Path, help="directories of seed_*.csv")
    parser.add_argument("--labels", nargs="*", help="one label per directory (default: its name)")
    parser.add_argument("--out", type=Path, default=Path("results.png"), help="PNG to write")
    parser.add_argument("--smooth", type=int, default=10, help="moving average, episodes")
    parser.add_argument(
        "--final",
        type=float,
        default=0.1,
        help="fraction of the last episodes that make the final return",
    )
    parser.add_argument(
        "--references",
        type=int,
        default=0,
        help="episodes of greedy and random play to draw (0: none)",
    )
    parser.add_argument(
        "--eval-epsilon",
        type=float,
        default=0.05,
        help="report the evaluations after training played at this epsilon",
    )
    parser.add_argument(
        "--by-agent",
        action="store_true",
        help="also draw each agent's mean return (multi-agent runs)",
    )
    parser.add_argument("--title", default=None, help="figure title (default: the scenario)")
    return parser.parse_args(argv)


def draw_runs(axes, args: argparse.Namespace) -> tuple[list[dict], str | None]:
    """Each directory's mean curve and band (and each agent's, with ``--by-agent``) on
    ``axes``: (each directory's row of the table, the scenario of the first)."""
    labels = args.labels or [d.parent.name for d in args.runs]
    rows, scenario = [], None
    for directory, label in zip(args.runs, labels):
        runs = load_runs(directory)
        if not runs:
            raise SystemExit(f"no seed_*.csv in {directory}")
        scenario = scenario or runs[0].summary.get("args", {}).get("scenario", directory.name)
        episodes, mean, half = curve(runs, args.smooth)
        line = axes.plot(episodes, mean, label=f"{label} ({len(runs)} seeds)")[0]
        axes.fill_between(episodes, mean - half, mean + half, color=line.get_color(), alpha=0.25)
        if args.by_agent and len(runs[0].agent_returns) > 1:
            for agent in sorted(runs[0].agent_returns):
                n = min(len(r.agent_returns[agent]) for r in runs)
                per_seed = [smooth(r.agent_returns[agent], args.smooth)[:n] for r in runs]
                axes.plot(
                    np.arange(1, n + 1),
                    np.mean(per_seed, 0),
                    lw=0.8,
                    alpha=0.7,
                    label=f"{label} {agent}",
                )
        rows.append(summarise(label, runs, args.smooth, args.final, args.eval_epsilon))
    return rows, scenario


def main(argv: list[str] | None = None) -> None:
    args = parse(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 5.2))
    rows, scenario = draw_runs(axes, args)
    reference_rows = references(scenario, args.references) if args.references else []
    for r, style in zip(reference_rows, ("--", ":")):
        axes.axhline(
            r["final"][0], color="gray", ls=style, lw=1, label=f"{r['label']} ({r['final'][0]:.0f})"
        )
    axes.set_xlabel("episode (500 steps)")
    axes.set_ylabel(f"return per episode\n(mean over seeds, {args.smooth}-episode average)")
    axes.set_title(args.title or f"{scenario}: mean and 95% t-interval over seeds")
    axes.grid(alpha=0.3)
    # Below the axes, so no curve or reference line is hidden behind it.
    axes.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, frameon=False)
    figure.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=150, bbox_inches="tight")
    print(f"wrote {args.out}\n")
    print(table(rows, reference_rows))


if __name__ == "__main__":
    main()
