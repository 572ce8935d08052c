"""The one bridge to pymunk (``flatland_ma.world.physics``): the only module that reaches
past pymunk's documented API; its tiers give the recorded trajectories to the bit; the
tier in use is the compiled one on the pinned pymunk, and a slower one is warned about."""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pymunk
import pytest

import flatland_ma
from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.world import physics, poses
from flatland_ma.world.tier import Tier, chosen
from tests.trajectories import MAX_CYCLES, load, own_spaces, replay_batch, replay_single

pytestmark = pytest.mark.pymunk_bridge

PACKAGE = Path(flatland_ma.__file__).parent
INTERNALS = re.compile(r"_chipmunk|\bffi\b|\blib\.cp|\._space\b|\._body\b|pymunk\._")
"""What reaching past pymunk's documented API looks like in source."""


def test_only_the_bridge_reaches_past_pymunks_documented_api():
    reaching = sorted(
        str(path.relative_to(PACKAGE))
        for path in PACKAGE.rglob("*.py")
        if INTERNALS.search(path.read_text())
    )
    assert reaching == ["world/physics.py"]


def test_the_pinned_pymunk_takes_the_compiled_tier():
    assert physics.BEST is Tier.COMPILED
    assert physics.TIER is Tier.COMPILED
    assert physics.describe().startswith("compiled (pymunk 7.")


@pytest.mark.parametrize("tier", [Tier.BATCH, Tier.ATTRIBUTES])
@pytest.mark.parametrize("scenario", ["fruits_poisons_multi", "coop_carry", "plate_relay"])
def test_every_tier_replays_the_recordings(scenario, tier, monkeypatch):
    """Single env and batch, in a slower tier: the same numbers to the bit (the compiled
    tier replays every scenario in tests/test_trajectories.py)."""
    monkeypatch.setattr(physics, "TIER", tier)
    replay_single(scenario)
    recording = load(scenario)
    n = len(recording["worlds"])
    batch = BatchedParallelEnv(scenario, num_worlds=n, max_cycles=MAX_CYCLES, pad=True)
    assert batch.core.motors is None  # only the compiled tier drives bodies from compiled code
    assert not batch.core.poses.compiled  # nor reads their poses so
    replay_batch(batch, recording, own_spaces(scenario), bodies=True)
    batch.close()


def _import_with(tier: str | None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != physics.VARIABLE}
    if tier is not None:
        env[physics.VARIABLE] = tier
    code = "from flatland_ma.world import physics; print(physics.describe())"
    return subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False
    )


def test_a_slower_tier_is_asked_for_by_name_and_warned_about_once():
    asked = _import_with("attributes")
    assert asked.returncode == 0, asked.stderr
    assert asked.stdout.startswith("attributes (pymunk 7.")
    assert "compiled is possible" in asked.stdout
    assert asked.stderr.count("RuntimeWarning") == 1
    assert "slower than the compiled one" in asked.stderr
    plain = _import_with(None)
    assert plain.stdout.startswith("compiled") and "RuntimeWarning" not in plain.stderr


def test_a_tier_of_no_name_fails_and_no_tier_beyond_the_best_is_given():
    wrong = _import_with("fastest")
    assert wrong.returncode != 0
    assert "FLATLAND_MA_PHYSICS='fastest': one of attributes, batch, compiled" in wrong.stderr
    assert chosen(Tier.BATCH, "compiled") is Tier.BATCH
    assert chosen(Tier.COMPILED, "Batch") is Tier.BATCH
    assert chosen(Tier.COMPILED, None) is Tier.COMPILED


def test_poses_read_through_pymunk_batch_are_the_attributes_through_changes():
    space, bodies = pymunk.Space(), []
    for k in range(6):
        body = pymunk.Body(1.0, 1.0)
        body.position, body.angle, body.velocity = (k * 1.5, -k), 0.1 * k, (1.0, k)
        body.center_of_gravity = (0.25, -0.5)
        space.add(body, pymunk.Circle(body, 0.5))
        bodies.append(body)
    space.add(pymunk.Body(body_type=pymunk.Body.KINEMATIC))  # a body not asked about
    batch = poses.SpacePoses(np.zeros((6, 3)), bodies)
    plain = poses.AttributePoses(np.zeros((6, 3)), bodies)
    assert isinstance(poses.poses_of(np.zeros((6, 3)), bodies), poses.SpacePoses)
    assert isinstance(poses.poses_of(np.zeros((2, 3)), bodies[:2]), poses.AttributePoses)
    for change in (None, "remove", "add"):
        if change == "remove":
            space.remove(bodies[2])  # retired: read through its attributes
        if change == "add":
            space.add(pymunk.Body(1.0, 1.0))
        space.step(0.01)
        batch.read()
        plain.read()
        np.testing.assert_array_equal(batch.pose, plain.pose)
