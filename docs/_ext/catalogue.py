"""A Sphinx extension that writes the catalogue: a page for every shipped scenario, task
stream and evaluation suite, read from the files themselves when the build starts.

The pages go to ``docs/catalogue/`` (git-ignored): a new scenario file gets its page at the
next build, and no page outlives its file.
"""

from __future__ import annotations

import json
from pathlib import Path

from pages import (
    body_of,
    code,
    compact,
    header_comment,
    literal_file,
    paragraphs,
    table,
    write_if_changed,
)
from pages import (
    picture as image,
)
from scenario_page import benchmark_section, scenario_page

from flatland_ma.envs.registration import gym_id, stream_gym_id
from flatland_ma.evaluation.suite import list_suites, load_suite, suite_dir
from flatland_ma.lifelong.streams import list_streams, load_stream
from flatland_ma.scenario.loader import list_scenarios, load_scenario, stream_dir

FOLDER = "catalogue"


def write_catalogue(docs: Path) -> list[Path]:
    """Write every page under ``docs/catalogue``; delete pages whose file is gone."""
    root = docs / FOLDER
    images = docs / "images"
    pages: dict[Path, str] = {}
    scenarios = list_scenarios()
    for name in scenarios:
        pages[root / "scenarios" / f"{name}.md"] = scenario_page(name, root / "scenarios", images)
    for name in list_streams():
        pages[root / "streams" / f"{name}.md"] = stream_page(name, root / "streams", docs)
    for name in list_suites():
        pages[root / "suites" / f"{name}.md"] = suite_page(name, root / "suites")
    pages[root / "index.md"] = index_page(scenarios, list_streams(), list_suites(), images)
    for path, text in pages.items():
        write_if_changed(path, text)
    for stale in root.rglob("*.md"):
        if stale not in pages:
            stale.unlink()
    return sorted(pages)


KIND_TITLES = {
    "forage": "Foraging and navigation",
    "parts": "Bodies with parts: pushing, grasping, carrying",
    "roles": "Roles, teams and talk",
    "senses": "Other senses",
}
"""The catalogue's groups of scenarios, in the order shown."""
THUMBNAIL_WIDTH = 120
"""Pixels across a scenario's picture in the catalogue's gallery."""


def kind_of(spec) -> str:
    """Which group of the gallery a scenario belongs to, from what its agents have:
    a channel or bodies of their own per team (roles), senses beyond a camera (senses),
    heads, arms or parts (parts), else foraging and navigation."""
    if spec.channel is not None or any(t.agent is not None for t in spec.teams or ()):
        return "roles"
    agents = [spec.agent_of(i) for i in range(spec.n_agents)]
    types = {s.type for agent in agents for s in agent.sensor_specs}
    if types != {"camera"}:
        return "senses"
    if any(a.head is not None or a.arms or a.parts for a in agents):
        return "parts"
    if any(o.movable for o in spec.obstacles):
        return "parts"
    return "forage"


def _observation(space) -> str:
    if hasattr(space, "spaces") and isinstance(space.spaces, dict):
        return ", ".join(f"{k} {tuple(s.shape)}" for k, s in space.spaces.items())
    return str(tuple(space.shape))


def _action(space) -> str:
    if hasattr(space, "n"):
        return f"Discrete({int(space.n)})"
    if hasattr(space, "nvec"):
        return f"MultiDiscrete({[int(n) for n in space.nvec]})"
    return f"Box{tuple(space.shape)}"


def gallery(scenarios: list[str], images: Path) -> list[str]:
    """The scenarios grouped by kind, each a row with its picture, agents, observation,
    action and Gymnasium id."""
    import flatland_ma

    groups: dict[str, list[list[object]]] = {kind: [] for kind in KIND_TITLES}
    for name in scenarios:
        spec = load_scenario(name)
        env = flatland_ma.parallel_env(name)
        first = env.possible_agents[0]
        observation = _observation(env.observation_space(first))
        action = _action(env.action_space(first))
        mixed = any(
            str(env.observation_space(a)) != str(env.observation_space(first))
            or str(env.action_space(a)) != str(env.action_space(first))
            for a in env.possible_agents
        )
        env.close()
        if mixed:
            observation += " (first agent's; others differ)"
        thumb = images / "scenarios" / f"{name}.png"
        picture_cell = (
            f"![{name}](../images/scenarios/{name}.png){{.thumb w={THUMBNAIL_WIDTH}px}}"
            if thumb.is_file()
            else ""
        )
        ident = gym_id(name)
        shown_id = code(ident) if ident in flatland_ma.GYM_IDS else "-"
        groups[kind_of(spec)].append(
            [
                picture_cell,
                f"[{name}](scenarios/{name}.md): {spec.description}",
                spec.n_agents,
                code(observation),
                code(action),
                shown_id,
            ]
        )
    out = []
    headers = ["", "Scenario", "Agents", "Observation", "Action", "Gymnasium id"]
    for kind, rows in groups.items():
        if rows:
            out += [f"### {KIND_TITLES[kind]}", "", table(headers, rows), ""]
    return out


def index_page(
    scenarios: list[str], streams: list[str], suites: list[str], images: Path | None = None
) -> str:
    shown = gallery(scenarios, images) if images is not None else []
    stream_rows = [[f"[{n}](streams/{n}.md)", load_stream(n).spec.description] for n in streams]
    suite_rows = [[f"[{n}](suites/{n}.md)", load_suite(n).description] for n in suites]
    toctree = ["```{toctree}", ":hidden:", ""]
    toctree += [f"scenarios/{n}" for n in scenarios]
    toctree += [f"streams/{n}" for n in streams] + [f"suites/{n}" for n in suites]
    return "\n".join(
        [
            "# Catalogue",
            "",
            "Every scenario, task stream and evaluation suite shipped with flatland_ma, each "
            "page generated from its file when this site is built.",
            "",
            "## Scenarios",
            "",
            "Grouped by what their agents have and do. Observation and action: the first "
            "agent's spaces (a `Dict` by sensor name when it has several sensors); "
            "Gymnasium id: for single-agent scenarios.",
            "",
            *shown,
            "## Task streams",
            "",
            "Lives through several tasks, for lifelong learning ([the guide](../lifelong.md)).",
            "",
            table(["Stream", "Description"], stream_rows),
            "",
            "## Evaluation suites",
            "",
            "Tasks with held-out partners and opponents (`flatland-ma evaluate`).",
            "",
            table(["Suite", "Description"], suite_rows),
            "",
            *toctree,
            "```",
            "",
        ]
    )


def _scenario_link(name: str) -> str:
    if name in list_scenarios():
        return f"[{name}](../scenarios/{name}.md)"
    return code(name)


def _overrides(overrides: dict) -> str:
    return code(json.dumps(overrides)) if overrides else "-"


def stream_page(name: str, page_dir: Path, docs: Path) -> str:
    path = stream_dir() / f"{name}.yaml"
    stream = load_stream(name)
    spec = stream.spec
    comment = header_comment(path)
    parts = [f"# {name} (stream)", "", f"*{spec.description}*", ""]
    picture = docs / "lifelong" / name / "lifelong.png"
    if picture.is_file():
        alt = f"{name}: the task-by-time performance matrix of the lifelong baselines"
        parts += image(picture, page_dir, alt, width=640)
    parts += [paragraphs(body_of(comment)), ""]
    parts += [
        "## Use",
        "",
        "| | |\n|---|---|",
        f"| Gymnasium | {code(f'gymnasium.make({stream_gym_id(name)!r})')} |",
        f"| PettingZoo | {code(f'flatland_ma.lifelong.StreamParallelEnv({name!r})')} |",
        f"| Baselines | {code(f'python -m baselines.lifelong --stream {name}')} |",
        f"| Evaluation | every {spec.eval.every} agent-steps, {spec.eval.episodes} episodes |",
        f"| Announced | {'yes: the observation names the task' if spec.announce else 'no'} |",
        "",
    ]
    if spec.tasks:
        segments = stream.segments()
        rows = [
            [
                task.name,
                _scenario_link(task.scenario),
                task.steps,
                ", ".join(task.focal) if task.focal else "all",
                task.background or "-",
                _overrides(task.overrides),
            ]
            for task in spec.tasks
        ]
        headers = ["Task", "Scenario", "Agent-steps", "Focal", "Background", "Overrides"]
        parts += ["## Tasks", "", table(headers, rows), ""]
        cycles = f"{spec.cycles} times over, " if spec.cycles > 1 else ""
        parts += [f"The life runs the tasks in this order, {cycles}{len(segments)} segments.", ""]
    if spec.never_ending is not None:
        ne = spec.never_ending
        parts += [
            "## One endless episode",
            "",
            f"The world of {_scenario_link(ne.scenario)} never ends; it drifts "
            f"({compact(ne.drift)}). Overrides: {_overrides(ne.overrides)}.",
            "",
        ]
    parts += benchmark_section(name, page_dir)
    parts += ["## The file", "", literal_file(path, page_dir), ""]
    return "\n".join(parts)


def suite_page(name: str, page_dir: Path) -> str:
    path = suite_dir() / f"{name}.yaml"
    suite = load_suite(name)
    parts = [f"# {name} (suite)", "", f"*{suite.description}*", ""]
    parts += [paragraphs(body_of(header_comment(path))), ""]
    parts += [
        "## Use",
        "",
        "```console",
        f"flatland-ma evaluate greedy --suite {name}",
        "```",
        "",
        "```python",
        "from flatland_ma.evaluation import load_suite, run_suite",
        "",
        f'result = run_suite(load_suite("{name}"), "greedy", episodes=1)',
        "```",
        "",
    ]
    if suite.training:
        parts += [f"Kept for training, never a background here: {', '.join(suite.training)}.", ""]
    rows = [
        [
            _scenario_link(task.scenario),
            ", ".join(task.focal),
            ", ".join(task.background),
            ", ".join(task.scripted),
            task.episodes,
            _overrides(task.overrides),
        ]
        for task in suite.tasks
    ]
    headers = ["Scenario", "Focal", "Background", "Scripted (score 1)", "Episodes", "Overrides"]
    parts += ["## Tasks", "", table(headers, rows), ""]
    parts += ["## The file", "", literal_file(path, page_dir), ""]
    return "\n".join(parts)


def _on_builder_inited(app) -> None:
    write_catalogue(Path(app.srcdir))


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
