"""Running a suite: the policy under test in the focal slots of each task, beside each
held-out background policy in turn; random play and the task's scripted policies in the
same slots, with the same partners and seeds, fix the scale (0 and 1) each task's returns
are normalised on. Also cross-play: every pair of policies, one per side, for Elo."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

import flatland_ma
from flatland_ma.evaluation.stats import elo, normalise, stratified_bootstrap
from flatland_ma.evaluation.suite import SuiteSpec, TaskSpec
from flatland_ma.policies.checkpoint import read_checkpoint
from flatland_ma.policies.named import is_checkpoint, make_policy
from flatland_ma.policies.rollout import play_episode

RANDOM = "random"


def focal_agents(env, names) -> list[str]:
    """The agents ``names`` (team names or agent names) stand for, in agent order."""
    spec, agents = env.spec, env.possible_agents
    chosen = set()
    for name in names:
        if name in agents:
            chosen.add(name)
            continue
        members = [
            a for i, a in enumerate(agents) if getattr(spec.team_of(i), "name", None) == name
        ]
        if not members:
            teams = [t.name for t in spec.teams]
            raise ValueError(
                f"no agent or team {name!r} in this scenario; agents: {agents}, teams: {teams}"
            )
        chosen.update(members)
    if len(chosen) == len(agents):
        raise ValueError("every agent is focal: a task needs background slots for its partners")
    return [a for a in agents if a in chosen]


def play(
    env, focal: list[str], policy: str, background: str, episodes: int, seed: int
) -> list[float]:
    """The focal agents' mean return in each of ``episodes`` episodes (seeds ``seed``,
    ``seed + 1``, ...), ``policy`` driving them and ``background`` every other agent."""
    policies = {
        a: make_policy(policy if a in focal else background, env, a, seed=seed + i)
        for i, a in enumerate(env.possible_agents)
    }
    returns = []
    for k in range(episodes):
        total, _ = play_episode(env, policies, seed + k)
        returns.append(float(np.mean([total[a] for a in focal])))
    return returns


def check_held_out(policy: str, suite: SuiteSpec) -> None:
    """Refuse a checkpoint that trained beside any of the suite's background policies (its
    ``trained_with``; the baselines' self-play writes ``["self"]``)."""
    if not is_checkpoint(policy):
        return
    partners = set(read_checkpoint(policy).get("trained_with") or ())
    clash = sorted(partners & suite.backgrounds())
    if clash:
        raise ValueError(
            f"{policy} trained beside {clash}, which this suite holds out as evaluation "
            "partners: its scores would not measure play with unseen partners"
        )


def run_task(
    task: TaskSpec,
    policy: str,
    seed: int = 0,
    episodes: int | None = None,
    fault: Callable[[tuple, str], Exception] | None = None,
) -> dict:
    """``policy`` scored on ``task``; a task whose scale cannot be set (its best scripted
    policy scores no more than random play) is refused with ``fault(("scripted",), message)``:
    the suite's fault at the task's key (file, line), when ``run_suite`` passes it."""
    env = flatland_ma.parallel_env(task.scenario, **task.overrides)
    focal = focal_agents(env, task.focal)
    label = f"{task.scenario} ({', '.join(task.focal)})"
    if is_checkpoint(policy):
        try:
            for a in focal:
                make_policy(policy, env, a)
        except ValueError as err:  # trained for other spaces than these agents'
            return {"scenario": task.scenario, "label": label, "focal": focal, "skipped": str(err)}
    n = episodes if episodes is not None else task.episodes

    def over_backgrounds(name: str) -> dict[str, list[float]]:
        return {b: play(env, focal, name, b, n, seed) for b in task.background}

    tested = over_backgrounds(policy)
    random = over_backgrounds(RANDOM)
    scripted = {name: over_backgrounds(name) for name in task.scripted}
    means = {
        name: float(np.mean([r for rs in runs.values() for r in rs]))
        for name, runs in scripted.items()
    }
    best = max(means, key=lambda name: means[name])
    random_mean = float(np.mean([r for rs in random.values() for r in rs]))
    runs = [r for rs in tested.values() for r in rs]
    try:
        scores = normalise(runs, random_mean, means[best]).tolist()
    except ValueError as err:
        message = f"task {label}: no scale to score on: {err}"
        if fault is None:
            raise ValueError(message) from None
        raise fault(("scripted",), message) from None
    point, low, high = stratified_bootstrap([scores], seed=seed)
    return {
        "scenario": task.scenario,
        "label": label,
        "focal": focal,
        "returns": tested,
        "random": random_mean,
        "scripted": means,
        "best_scripted": best,
        "normalised": scores,
        "mean": float(np.mean(scores)),
        "iqm": point,
        "ci": [low, high],
    }


def run_suite(
    suite: SuiteSpec,
    policy: str,
    seed: int = 0,
    episodes: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict:
    """Every task of ``suite`` for ``policy``, and the interquartile mean of every
    normalised run with its stratified bootstrap 95% interval. A checkpoint is scored on
    the tasks whose focal agents' spaces it was trained for; the others are listed as
    skipped, with the reason."""
    check_held_out(policy, suite)
    tasks = []
    for t, task in enumerate(suite.tasks):
        if progress is not None:
            progress(
                f"task {t + 1}/{len(suite.tasks)}: {task.scenario} (focal {', '.join(task.focal)})"
            )

        def fault(path: tuple, message: str, t: int = t) -> Exception:
            return suite.fault(("tasks", t, *path), message)

        tasks.append(run_task(task, policy, seed, episodes, fault))
    scored = [t for t in tasks if "skipped" not in t]
    if not scored:
        raise ValueError(f"{policy} fits none of the suite's tasks: {tasks[0]['skipped']}")
    point, low, high = stratified_bootstrap([t["normalised"] for t in scored], seed=seed)
    return {
        "policy": policy,
        "seed": seed,
        "tasks": tasks,
        "aggregate": {
            "iqm": point,
            "ci": [low, high],
            "mean": float(np.mean([t["mean"] for t in scored])),
        },
    }


def crossplay(
    scenario: str, policies: list[str], episodes: int = 4, seed: int = 0, **overrides
) -> dict:
    """Each policy driving the first team against each other driving the rest: the first
    team's share of wins (its return above the others' mean; a tie counts a half), and Elo
    ratings fitted to it."""
    env = flatland_ma.parallel_env(scenario, **overrides)
    if not env.spec.teams or len(env.spec.teams) < 2:
        raise ValueError(f"cross-play needs a scenario of two teams or more; {scenario} has none")
    first = focal_agents(env, [env.spec.teams[0].name])
    n = len(policies)
    wins = np.zeros((n, n))
    for i, mine in enumerate(policies):
        for j, theirs in enumerate(policies):
            if i == j:
                continue
            wins[i, j] = _first_team_wins(env, first, mine, theirs, episodes, seed)
    table: list[list[float | None]] = [list(row) for row in wins.tolist()]
    for i in range(n):
        table[i][i] = None  # not played
    return {
        "scenario": scenario,
        "policies": policies,
        "wins": table,
        "elo": elo(wins).tolist(),
    }


def _first_team_wins(env, first, mine, theirs, episodes, seed) -> float:
    policies = {
        a: make_policy(mine if a in first else theirs, env, a, seed=seed + i)
        for i, a in enumerate(env.possible_agents)
    }
    score = 0.0
    for k in range(episodes):
        total, _ = play_episode(env, policies, seed + k)
        ours = np.mean([total[a] for a in first])
        others = np.mean([v for a, v in total.items() if a not in first])
        score += 1.0 if ours > others else 0.5 if ours == others else 0.0
    return score / episodes


def write_report(result: dict, out: Path, plot: bool = True) -> list[Path]:
    """The result as JSON, and a plot of each task's normalised score (mean, with its 95%
    interval) and the aggregate interquartile mean, in ``out``."""
    import json

    out.mkdir(parents=True, exist_ok=True)
    written = [out / "evaluation.json"]
    written[0].write_text(json.dumps(result, indent=2))
    if plot and "tasks" in result:
        written.append(_plot(result, out / "evaluation.png"))
    return written


def write_crossplay(result: dict, out: Path, plot: bool = True) -> list[Path]:
    """A cross-play result as JSON, and its matrix as a picture with the Elo ratings."""
    import json

    out.mkdir(parents=True, exist_ok=True)
    written = [out / "crossplay.json"]
    written[0].write_text(json.dumps(result, indent=2))
    if not plot:
        return written
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [f"{Path(p).name} ({r:.0f})" for p, r in zip(result["policies"], result["elo"])]
    wins = np.array(result["wins"], dtype=float)
    fig, ax = plt.subplots(figsize=(1.2 * len(names) + 3, 0.8 * len(names) + 2))
    image = ax.imshow(wins, vmin=0, vmax=1, cmap="RdYlGn")
    for (i, j), value in np.ndenumerate(wins):
        ax.text(j, i, "-" if np.isnan(value) else f"{value:.2f}", ha="center", va="center")
    ax.set_xticks(range(len(names)), [Path(p).name for p in result["policies"]])
    ax.set_yticks(range(len(names)), names)
    ax.set_xlabel("the other teams' policy")
    ax.set_ylabel("the first team's policy (Elo)")
    ax.set_title(f"{result['scenario']}: the first team's share of wins")
    fig.colorbar(image, ax=ax)
    fig.tight_layout()
    written.append(out / "crossplay.png")
    fig.savefig(written[-1], dpi=100)
    plt.close(fig)
    return written


def _plot(result: dict, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = [t for t in result["tasks"] if "skipped" not in t]
    labels = [t["label"] for t in tasks] + ["IQM, all tasks"]
    points = [t["iqm"] for t in tasks] + [result["aggregate"]["iqm"]]
    cis = [t["ci"] for t in tasks] + [result["aggregate"]["ci"]]
    errors = np.array([[p - lo, hi - p] for p, (lo, hi) in zip(points, cis)]).T
    fig, ax = plt.subplots(figsize=(7, 0.45 * len(labels) + 1.2))
    y = np.arange(len(labels))[::-1]
    ax.barh(y, points, xerr=errors, color=["#6a9fd8"] * len(tasks) + ["#d8866a"], capsize=3)
    ax.axvline(0.0, color="grey", lw=0.8)
    ax.axvline(1.0, color="grey", lw=0.8, ls="--")
    ax.set_yticks(y, labels)
    ax.set_xlabel("normalised score (random 0, best scripted 1): IQM, 95% stratified bootstrap CI")
    ax.set_title(f"{Path(str(result['policy'])).name}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def table(result: dict) -> str:
    """The result as a text table: per task the mean focal return of random play, of the
    best scripted policy and of the policy, then the policy's normalised mean and IQM with
    its 95% interval."""
    head = f"{'task':32} {'random':>7} {'best scripted':>18} {'policy':>7}"
    lines = [head + f" {'mean':>6} {'IQM':>6}  95% CI"]
    for t in result["tasks"]:
        if "skipped" in t:
            lines.append(f"{t['label']:32} skipped: {t['skipped'][:80]}")
            continue
        returns = np.mean([r for rs in t["returns"].values() for r in rs])
        best = f"{t['best_scripted']} {t['scripted'][t['best_scripted']]:.3g}"
        low, high = t["ci"]
        lines.append(
            f"{t['label']:32} {t['random']:7.3g} {best:>18} {returns:7.3g} {t['mean']:6.2f}"
            f" {t['iqm']:6.2f}  [{low:.2f}, {high:.2f}]"
        )
    agg = result["aggregate"]
    low, high = agg["ci"]
    lines.append(
        f"{'all tasks (normalised)':32} {'':34} {agg['mean']:6.2f} {agg['iqm']:6.2f}"
        f"  [{low:.2f}, {high:.2f}]"
    )
    return "\n".join(lines)
