"""Tiny ``baselines.ppo`` runs for the tests: a few updates, no checkpoints on the way, no
TensorBoard, a small network, the log (and final checkpoint) in the test's folder."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from baselines import ppo


def tiny_args(folder: Path, **options) -> ppo.Args:
    """A run of two updates of one world on ``fruits_poisons`` unless ``options`` say
    otherwise, logging to ``folder/seed_0.csv``."""
    base = ppo.Args(
        scenario="fruits_poisons",
        num_envs=1,
        num_steps=32,
        total_timesteps=64,
        checkpoint_every=0,
        tensorboard=False,
        hidden=32,
        csv=str(folder / "seed_0.csv"),
    )
    return replace(base, **options)
