"""One generated page per shipped scenario, read from its file and from the env it builds."""

from __future__ import annotations

import json
import os
import statistics
from pathlib import Path

from pages import (
    body_of,
    code,
    compact,
    header_comment,
    literal_file,
    paragraphs,
    picture,
    space_rows,
    split_scores,
    table,
)
from tried import tried_section

import flatland_ma
from flatland_ma.envs.registration import gym_id
from flatland_ma.scenario.colors import color_text
from flatland_ma.scenario.loader import load_scenario, scenario_path
from flatland_ma.scenario.schema import ScenarioSpec

DOCS = Path(__file__).resolve().parent.parent
BENCHMARK = DOCS.parent / "results" / "benchmark" / "summary.json"
"""Each task's benchmark figures, written by ``make benchmark-table``."""
REACH = DOCS.parent / "results" / "reach.json"
"""Where each scenario first pays, by play (``python -m baselines.benchmark.reach``)."""
EXAMPLE_SPEED = 150
"""The ``agent.max_speed`` of every page's override example (valid in every scenario)."""


def scenario_page(name: str, page_dir: Path, images: Path) -> str:
    """The Markdown page of scenario ``name``, to be written into ``page_dir``."""
    path = scenario_path(name)
    spec = load_scenario(name)
    env = flatland_ma.parallel_env(name)
    try:
        agents = _agents(spec, env)
        state = env.state_space
    finally:
        env.close()
    prose, scores = split_scores(body_of(header_comment(path)))
    parts = [f"# {name}", "", f"*{spec.description}*", ""]
    parts += _pictures(name, page_dir, images)
    parts += [paragraphs(prose), ""]
    parts += _summary(name, spec, sum(len(g["names"]) for g in agents), state)
    parts += ["## Agents", "", _agents_table(agents), ""]
    parts += _observations(agents)
    parts += _rules(spec)
    parts += _endings(spec)
    parts += ["## Reference scores", ""]
    if scores:
        parts += [paragraphs(scores), ""]
    if spec.reference is not None:
        ref = spec.reference
        parts += [
            f"The tests require the reference solver {code(ref.solver)} to score at least "
            f"{ref.min_score:g} over {ref.episodes} episodes.",
            "",
        ]
    parts += benchmark_section(name, page_dir)
    parts += reach_section(name, page_dir)
    parts += curve_section(name, page_dir)
    parts += tried_section(name, page_dir)
    parts += _overrides(name, spec)
    parts += ["## The file", "", literal_file(path, page_dir), ""]
    return "\n".join(parts)


def benchmark_section(name: str, page_dir: Path) -> list[str]:
    """A scenario's or stream's figures from the benchmark (IQM over seeds, 95% interval),
    if any."""
    if not BENCHMARK.is_file():
        return []
    row = json.loads(BENCHMARK.read_text(encoding="utf-8")).get(name)
    if row is None or row["random"] is None:
        return []

    def shown(x) -> str:
        if x is None:
            return "not yet run"
        return f"{x['iqm']:.3g} ({x['low']:.3g} to {x['high']:.3g}), {x['seeds']} seed" + (
            "s" if x["seeds"] != 1 else ""
        )

    page = os.path.relpath(DOCS / "benchmark.md", page_dir)
    rows = [
        ["random play", shown(row["random"])],
        ["scripted reference", shown(row["scripted"])],
        [f"PPO, {row['budget']:,} agent-steps", shown(row["ppo"])],
    ]
    if row["normalised"] is not None:
        rows.append(["PPO, normalised (random 0, scripted 1)", shown(row["normalised"])])
    out = ["## Benchmark", ""]
    out += [table(["Method", "Score: IQM over seeds (95% interval)"], rows), ""]
    if row["verdict"]:
        out += [f"Verdict: **{row['verdict']}**.", ""]
    out += [
        f"Held-out episodes and the verdicts are described on the [benchmark page]({page}).",
        "",
    ]
    return out


def reach_section(name: str, page_dir: Path) -> list[str]:
    """How often random and scripted play are paid in an episode, and how early, if
    measured."""
    if not REACH.is_file():
        return []
    row = json.loads(REACH.read_text(encoding="utf-8")).get(name)
    if row is None:
        return []

    def said(method: str) -> str:
        r = row[method]
        firsts = sorted(s for s in r["first_steps"] if s is not None)
        if not firsts:
            return f"in none of its {r['episodes']} episodes"
        median = statistics.median(firsts)
        return f"in {r['paid']} of {r['episodes']} episodes, first at step {median:g} (median)"

    page = os.path.relpath(DOCS / "benchmark.md", page_dir)
    text = (
        f"Before any training, on the benchmark's held-out episodes (step limit "
        f"{row['random']['limit']}): random play is paid {said('random')}; the scripted "
        f"solver {said('scripted')}."
    )
    if row["random"]["paid"] == 0:
        text += (
            " Random play never finds the reward here, so a learner starting from it must "
            "find the reward by exploring before it can learn anything."
        )
    return [
        "### Where the reward lies",
        "",
        text,
        "",
        f'More on [the benchmark page]({page}), section "Where the reward lies".',
        "",
    ]


def curve_section(name: str, page_dir: Path) -> list[str]:
    """The scenario's learning curve from the benchmark (docs/images/curves/, drawn by
    ``make benchmark-table`` from the committed results), if there is one."""
    path = DOCS / "images" / "curves" / f"{name}.png"
    if not path.is_file():
        return []
    alt = f"{name}: PPO's training return over agent-steps, IQM over seeds with 95% intervals"
    return [
        "### Learning curve",
        "",
        *picture(path, page_dir, alt, width=560),
        "PPO's return while training at 50 checkpoints of each seed: the interquartile mean "
        "over seeds, shaded between its 95% bootstrap interval, per tier of the benchmark; "
        "random, scripted and open-loop play's held-out scores as lines.",
        "",
    ]


def _pictures(name: str, page_dir: Path, images: Path) -> list[str]:
    out = []
    still = images / "scenarios" / f"{name}.png"
    moving = images / "tasks" / f"{name}.gif"
    if not moving.is_file():  # the short animation of make docs (docs/_ext/animations.py)
        moving = images / "animations" / f"{name}.gif"
    if moving.is_file():
        out += picture(moving, page_dir, f"{name}: an episode of its scripted solver")
    if still.is_file():
        alt = f"{name}: the world from above, after 60 steps of the planner"
        out += picture(still, page_dir, alt)
    return out


def _summary(name: str, spec: ScenarioSpec, env_agents: int, state) -> list[str]:
    rows = [
        ["Import", code(f'flatland_ma.parallel_env("{name}")')],
        ["AEC", code(f'flatland_ma.env("{name}")')],
    ]
    ident = gym_id(name)
    if ident in flatland_ma.GYM_IDS:
        rows.append(["Gymnasium", code(f'gymnasium.make("{ident}")')])
    else:
        rows.append(["Gymnasium", f"none: {env_agents} agents (use the PettingZoo envs)"])
    rows.append(["Agents", str(env_agents)])
    rows.append(["Episode", f"{spec.episode.max_steps} steps of {spec.physics.dt:.4g} s"])
    if spec.teams:
        rows.append(["Teams", ", ".join(f"{t.name} ({t.size})" for t in spec.teams)])
    if spec.channel is not None:
        rows.append(["Channel", settings(spec.channel)])
    rows.append(
        [
            "Global state",
            f"{code('env.state()')}: {state.shape[0]} float32 numbers "
            f"({code('env.state_labels')} names each; see [the concepts](../../concepts.md))",
        ]
    )
    return ["## At a glance", "", "| | |\n|---|---|", *[f"| {a} | {b} |" for a, b in rows], ""]


def _agents(spec: ScenarioSpec, env) -> list[dict]:
    """Agents with the same team, observation and actions, grouped in agent order."""
    groups: list[dict] = []
    for i, agent in enumerate(env.possible_agents):
        body = spec.agent_of(i)
        team = spec.team_of(i)
        key = (
            team.name if team else None,
            str(env.observation_space(agent)),
            str(env.action_space(agent)),
            env.action_names(agent),
        )
        if groups and groups[-1]["key"] == key:
            groups[-1]["names"].append(agent)
            continue
        groups.append(
            {
                "key": key,
                "names": [agent],
                "team": team.name if team else "",
                "body": body,
                "observation": env.observation_space(agent),
                "action": env.action_space(agent),
                "action_names": env.action_names(agent),
            }
        )
    return groups


def _label(group: dict) -> str:
    names = group["names"]
    return names[0] if len(names) == 1 else f"{names[0]} to {names[-1]}"


def _body(agent) -> str:
    parts = [f"disc of radius {agent.radius:g}, mass {agent.mass:g}"]
    if agent.head is not None:
        parts.append("a head")
    for arm in agent.arms:
        grip = " with a grasper" if arm.grasper is not None else ""
        parts.append(f"an arm of {len(arm.segments)} segment(s){grip}")
    parts.append(f"top speed {agent.max_speed:g}")
    return "; ".join(parts)


def _agents_table(groups: list[dict]) -> str:
    rows = []
    for g in groups:
        sensors = ", ".join(f"{s.name or s.type}" for s in g["body"].sensor_specs)
        actions = f"{code(g['action'])}: " + ", ".join(g["action_names"])
        rows.append([_label(g), g["team"] or "-", _body(g["body"]), sensors, actions])
    return table(["Agents", "Team", "Body", "Sensors", "Actions (env.action_names)"], rows)


def _observations(groups: list[dict]) -> list[str]:
    out = ["## Observations", ""]
    out += [
        "Read from `env.observation_space(agent)` of the built env; each sensor's settings "
        "with their values, whether the file sets them or leaves the scenario format's "
        "defaults.",
        "",
    ]
    for g in groups:
        if len(groups) > 1:
            out += [f"### {_label(g)}", ""]
        out += [table(["Entry", "Shape", "Dtype", "Values"], space_rows(g["observation"])), ""]
        rows = [[code(s.name or s.type), s.type, settings(s)] for s in g["body"].sensor_specs]
        out += [table(["Sensor", "Type", "Settings (every value, defaults included)"], rows), ""]
        for s in g["body"].sensor_specs:
            if s.type == "camera":
                out += _camera_channels(s)
    return out


def settings(spec) -> str:
    """Every setting of a spec with its value, defaults included (``key=value``; colours
    by name; unset optional ones left out)."""
    data = spec.model_dump(mode="json", exclude_none=True)
    pairs = [f"{k}={_value(v)}" for k, v in data.items() if k not in ("type", "name")]
    return ", ".join(pairs) or "none"


def _value(value) -> str:
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_value(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    return str(value)


KINDS = "0 nothing, 1 wall, 2 door, 3 obstacle, 4 item, 5 agent"
"""The semantic channel's kinds, as ``CameraSpec.channels`` documents them."""


def _camera_channels(camera) -> list[str]:
    """What each column of a camera's observation means, in order."""
    name = code(camera.name or camera.type)
    fade = {
        "linear": f"1 - d / {camera.range:g}",
        "exponential": f"exp(-d / {camera.decay or camera.range / 3:g})",
        "none": "1",
    }[camera.falloff]
    rows, k = [], 0
    for channel in camera.channels:
        if channel == "rgb":
            rows.append(
                [f"{k}, {k + 1}, {k + 2}", "red, green, blue of the first thing the ray hits, "
                 f"times its intensity {code(fade)} for a hit at distance d; black for nothing"]
            )  # fmt: skip
            k += 3
        elif channel == "depth":
            rows.append([str(k), f"depth: {code(f'd / {camera.range:g}')}; 1 for nothing in range"])
            k += 1
        elif camera.semantic == "id":
            rows.append([str(k), f"the kind of thing hit, as its id ({KINDS})"])
            k += 1
        else:
            rows.append([f"{k} to {k + 5}", f"the kind of thing hit, one-hot ({KINDS})"])
            k += 6
    intro = (
        f"The camera {name} gives one row per ray ({camera.rays} rays over {camera.fov:g} "
        f"degrees, ray 0 the leftmost) and {k} channels per ray:"
    )
    return [intro, "", table(["Channel", "Meaning"], rows), ""]


def _rules(spec: ScenarioSpec) -> list[str]:
    out = ["## Rules and rewards", ""]
    if spec.items:
        rows = [
            [i.name, color_text(i.color), f"{i.reward:g}", i.count, i.respawn, _flags(i)]
            for i in spec.items
        ]
        headers = ["Items", "Colour", "Reward", "Count", "Respawn", "Also"]
        out += [table(headers, rows), ""]
    if spec.zones:
        rows = [
            [z.name or f"zone {k}", f"{z.reward:g}", compact(z, drop=("name", "reward"))]
            for k, z in enumerate(spec.zones)
        ]
        out += [table(["Zones", "Reward on entry", "Settings"], rows), ""]
    if spec.doors:
        rows = [
            [d.name or f"door {k}", compact(d, drop=("name",))] for k, d in enumerate(spec.doors)
        ]
        out += [table(["Doors", "Settings"], rows), ""]
    if spec.rules:
        rows = [[r.rule, f"{r.reward:g}", compact(r, drop=("rule", "reward"))] for r in spec.rules]
        out += [table(["Rules (in order)", "Reward", "Settings"], rows), ""]
    if len(out) == 2:
        out += ["No rewards: the scenario is a world to explore.", ""]
    return out


def _flags(item) -> str:
    flags = [f for f in ("terminal", "shared", "key") if getattr(item, f)]
    return ", ".join(flags) or "-"


def _endings(spec: ScenarioSpec) -> list[str]:
    ends = [f"Every agent is truncated after {spec.episode.max_steps} steps (`max_cycles`)."]
    for item in spec.items:
        if item.terminal:
            ends.append(f"Taking a {item.name} item terminates the agent that took it.")
    for k, zone in enumerate(spec.zones):
        label = zone.name or f"zone {k}"
        if zone.terminal:
            ends.append(f"Entering {label} terminates the agent.")
        if zone.end_on_delivery:
            ends.append(f"Delivering {zone.accepts} into {label} ends the episode.")
    if spec.episode.shared_end:
        ends.append("When one agent's episode ends, everyone's does (`shared_end`).")
    if spec.episode.end_when_eaten:
        ends.append(f"The episode ends when no {spec.episode.end_when_eaten} item is left.")
    return ["## Endings", "", *[f"- {e}" for e in ends], ""]


def _overrides(name: str, spec: ScenarioSpec) -> list[str]:
    longer = 2 * spec.episode.max_steps
    example = {"episode": {"max_steps": longer}, "agent": {"max_speed": EXAMPLE_SPEED}}
    load_scenario(name, **example)  # the example on the page is a valid one
    lines = [
        "## Overrides",
        "",
        "Any top-level key of the file can be overridden from Python; mappings merge key by "
        "key and lists replace the file's whole (see [the scenario format](../../scenarios.md)). "
        "A longer episode with slower agents:",
        "",
        "```python",
        "import flatland_ma",
        "",
        f'env = flatland_ma.parallel_env("{name}", max_cycles={longer}, '
        f'agent={{"max_speed": {EXAMPLE_SPEED}}})',
    ]
    ident = gym_id(name)
    if ident in flatland_ma.GYM_IDS:
        lines += [
            "",
            "import gymnasium",
            "",
            f'env = gymnasium.make("{ident}", max_episode_steps={longer}, '
            f'agent={{"max_speed": {EXAMPLE_SPEED}}})',
        ]
    return [*lines, "```", ""]
