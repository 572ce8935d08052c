"""The extending guide's examples work as printed: its code blocks that start with a
``# <path>`` line are copied into a package outside the repository, registered, and run
in a scenario: the item radar reads the nearest visible item, the first-bite rule pays
once per agent from ``step.log.items``, and the pillars stand where the generator put
them, clear of the walls and on the navigation grid."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
GUIDE = ROOT / "docs" / "extending.md"

CHECK = r"""
import json, math, sys
from pathlib import Path

import numpy as np

import flatland_ma
import guide_world
from flatland_ma.policies import GreedyForager
from flatland_ma.world.entities import Item, Obstacle

guide_world.register()
home = Path(sys.argv[1])
env = flatland_ma.parallel_env(str(home / "world.yaml"))
obs, _ = env.reset(seed=0)
world = env.episode.world
found = {"space": list(env.observation_space("agent_0")["item_radar"].shape)}
body = env.episode.bodies[0].body
items = [i for i in world.of_type(Item) if i.visible]
nearest = min(items, key=lambda i: (i.body.position - body.position).length)
found["radar"] = [float(v) for v in obs["agent_0"]["item_radar"]]
found["nearest"] = (nearest.body.position - body.position).length / 150.0
pillars = [o for o in world.of_type(Obstacle) if abs(o.body.position.y - 150) <= 20.5]
found["pillars"] = [[float(o.body.position.x), float(o.body.position.y)] for o in pillars]
grid = env.episode.grid
found["blocked"] = [bool(grid.blocked[grid.cell_of(*p)]) for p in found["pillars"]]
policy = GreedyForager(env.spec)
bites = []
for t in range(300):
    obs, rewards, terms, truncs, infos = env.step({"agent_0": policy.act(obs["agent_0"])})
    bites.append(infos["agent_0"]["first_bite"])
    if not env.agents:
        break
info = infos["agent_0"]
found.update(bites=bites, fruits=info["fruits"], poisons=info["poisons"], score=info["score"])
print(json.dumps(found))
"""


def guide_files() -> dict[str, str]:
    """Each code block of the guide whose first line is ``# <path>``, by that path."""
    text = GUIDE.read_text(encoding="utf-8")
    blocks = re.findall(r"```(?:python|yaml)\n# (\S+)\n(.*?)```", text, re.S)
    return {path: body for path, body in blocks}


def test_the_guide_holds_a_whole_package():
    assert sorted(guide_files()) == [
        "guide_world/__init__.py",
        "guide_world/first_bite.py",
        "guide_world/pillars.py",
        "guide_world/radar.py",
        "world.yaml",
    ]


@pytest.fixture(scope="module")
def found(tmp_path_factory):
    home = tmp_path_factory.mktemp("guide")
    for name, text in guide_files().items():
        path = home / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    env = {"PYTHONPATH": ":".join([str(home), *sys.path[1:]]), "PATH": "/usr/bin:/bin"}
    done = subprocess.run(
        [sys.executable, "-c", CHECK, str(home)],
        capture_output=True,
        text=True,
        env=env,
        timeout=900,  # a kill for a hung run only: it takes seconds
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_radar_reads_the_nearest_visible_item(found):
    cos, sin, distance = found["radar"]
    assert found["space"] == [3]
    assert cos**2 + sin**2 == pytest.approx(1.0, abs=1e-5)
    assert distance == pytest.approx(min(found["nearest"], 1.0), abs=1e-4)


def test_the_pillars_stand_across_the_middle_and_block_the_grid(found):
    xs = sorted(x for x, _ in found["pillars"])
    assert xs == pytest.approx([75.0, 150.0, 225.0])
    assert all(found["blocked"])


def test_the_first_bite_pays_once_from_the_contact_log(found):
    bites = found["bites"]
    assert found["fruits"] >= 2 and bites[-1] is True
    first = bites.index(True)
    assert all(bites[first:])  # stays bitten: paid once
    paid = 10 * found["fruits"] - 10 * found["poisons"] + 5.0  # the items' rewards, one bonus
    assert found["score"] == pytest.approx(paid)
