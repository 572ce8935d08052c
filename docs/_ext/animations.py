"""The short animation on every scenario page that has no recording of its own: an
episode's first steps played by the scenario's reference solver, small (few frames, a
reduced size) so that the site stays light.

Run by ``make docs`` (``python docs/_ext/animations.py``), which writes
``docs/images/animations/<scenario>.gif`` for each shipped scenario without a
``docs/images/tasks/<scenario>.gif``; the pages show whichever exists.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image

import flatland_ma
from flatland_ma.policies.named import make_policy
from flatland_ma.render.video import save_gif

DOCS = Path(__file__).resolve().parent.parent
FOLDER = DOCS / "images" / "animations"
TASKS = DOCS / "images" / "tasks"
STEPS = 240
"""Steps recorded at most (the episode may end sooner)."""
EVERY = 8
"""One frame kept in this many steps (and the last): about 30 frames."""
WIDTH = 280
"""Pixels across each frame, scaled down from the renderer's."""
FPS = 8.0
"""Frames a second of the GIF: 30 frames make four seconds."""
SEED = 1


def policies_for(env, spec) -> dict:
    """Each agent's policy: the scenario's reference solver, team by team."""
    reference = spec.reference
    names = {}
    for i, agent in enumerate(env.possible_agents):
        team = spec.team_of(i)
        solver = reference.solver if reference is not None else "planner"
        if solver == "teams":
            solver = reference.teams[spec.teams.index(team)]
        elif solver == "carrier_vs_random":
            solver = "carrier" if team is None or team is spec.teams[0] else "random"
        names[agent] = solver
    return {a: make_policy(n, env, a, SEED) for a, n in names.items()}


def small(frame: np.ndarray) -> np.ndarray:
    height = round(frame.shape[0] * WIDTH / frame.shape[1])
    return np.asarray(Image.fromarray(frame).resize((WIDTH, height), Image.Resampling.LANCZOS))


def animate(name: str, out: Path) -> Path:
    """Record scenario ``name`` into ``out``."""
    spec = flatland_ma.load_scenario(name)
    env = flatland_ma.parallel_env(name, render_mode="rgb_array")
    observations, _ = env.reset(seed=SEED)
    agents = policies_for(env, spec)
    frames = [small(env.render())]
    for t in range(STEPS):
        if not env.agents:
            break
        actions = {a: agents[a].act(observations[a]) for a in env.agents}
        observations, *_ = env.step(actions)
        if (t + 1) % EVERY == 0 or not env.agents:
            frames.append(small(env.render()))
    env.close()
    return save_gif(frames, out, fps=FPS)


def main(names: list[str]) -> None:
    for name in names or flatland_ma.list_scenarios():
        if (TASKS / f"{name}.gif").is_file():
            continue
        path = animate(name, FOLDER / f"{name}.gif")
        print(f"wrote {path.relative_to(DOCS.parent)} ({path.stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main(sys.argv[1:])
