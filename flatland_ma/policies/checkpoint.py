"""A trained network saved by the baselines, played as a policy.

A checkpoint is one file written by ``torch.save``: a dict with the network as an exported
program (``torch.export``) that maps a batch of raw observations, exactly as the env gives
them, to action logits, so playing it needs neither the training code nor its classes;
beside it the scenario, the spaces, the training arguments and the trainer's own state
(parameters, optimiser) for resuming. ``write_checkpoint`` (used by the baselines) writes
one; ``CheckpointPolicy`` plays one::

    policy = CheckpointPolicy("runs/ppo/fruits_poisons/seed_0.pt")
    action = policy.act(observation)

torch is needed (the ``train`` extra); it is imported only when a checkpoint is used.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any

import numpy as np

FORMAT = "flatland_ma.policy"
VERSION = 1


def write_checkpoint(
    path: str | Path,
    network: Any,
    example: np.ndarray,
    *,
    scenario: str,
    observation_space: Any,
    action_space: Any,
    extra: dict | None = None,
) -> Path:
    """Save ``network`` (a torch module from a batch of raw observations like ``example``,
    shape (batch, ...), or a dict of such batches for a ``Dict`` space, to logits) with
    the facts needed to play it; ``extra`` holds anything else to keep (arguments, the
    trainer's state). For a ``MultiDiscrete`` action space the logits of its components
    come joined along the last axis. Written to a temporary file and moved into place, so
    a reader never sees half a checkpoint."""
    import torch
    from torch.utils._pytree import tree_map

    batch = torch.export.Dim("batch")

    def two(x) -> torch.Tensor:  # export needs an example batch of two to leave it free
        x = torch.as_tensor(np.ascontiguousarray(x[:2]))
        return torch.cat([x, x]) if len(x) == 1 else x

    inputs = tree_map(two, example)
    network.eval()
    try:
        program = torch.export.export(
            network, (inputs,), dynamic_shapes=(tree_map(lambda _: {0: batch}, inputs),)
        )
    finally:
        network.train()
    buffer = io.BytesIO()
    torch.export.save(program, buffer)
    data = {
        "format": FORMAT,
        "version": VERSION,
        "scenario": scenario,
        "observation_space": str(observation_space),
        "action_space": str(action_space),
        "action_sizes": _action_sizes(action_space),
        "program": buffer.getvalue(),
        **(extra or {}),
    }
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_name(path.name + ".part")
    torch.save(data, part)
    os.replace(part, path)
    return path


def _action_sizes(space: Any) -> list[int]:
    """The number of choices of each component of a ``Discrete`` (one) or
    ``MultiDiscrete`` action space."""
    nvec = getattr(space, "nvec", None)
    return [int(space.n)] if nvec is None else [int(n) for n in np.asarray(nvec).ravel()]


def read_checkpoint(path: str | Path) -> dict:
    """The checkpoint's dict, checked to be one; errors name the file."""
    try:
        import torch
    except ImportError as err:
        raise ValueError(
            f"{path}: playing a checkpoint needs torch (pip install 'flatland-ma[train]')"
        ) from err
    if not Path(path).is_file():
        raise ValueError(f"{path}: no such checkpoint file")
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # a file torch cannot read: say which and why
        raise ValueError(f"{path}: not a checkpoint torch can read ({err})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError(f"{path}: not a flatland_ma policy checkpoint")
    if data.get("version") != VERSION:
        raise ValueError(
            f"{path}: checkpoint version {data.get('version')}, this flatland_ma reads {VERSION}"
        )
    return data


class CheckpointPolicy:
    """Plays a saved network: samples from its action distribution with its own seeded
    generator, or takes the most likely action when ``greedy``."""

    def __init__(self, path: str | Path, greedy: bool = False, seed: int | None = None):
        import torch

        self.path = Path(path)
        self.data = read_checkpoint(path)
        self.scenario: str = self.data["scenario"]
        self.program = torch.export.load(io.BytesIO(self.data["program"])).module()
        self.greedy = greedy
        self.rng = np.random.default_rng(seed)
        self._padding: tuple | None = None
        """The padding of the agent played (see ``bind``), or None."""

    def check(self, observation_space, action_space) -> None:
        """Raise ``ValueError`` unless the agent's spaces are those the network learnt on."""
        for what, space in (("observation", observation_space), ("action", action_space)):
            saved = self.data[f"{what}_space"]
            if str(space) != saved:
                raise ValueError(
                    f"{self.path}: trained for the {what} space {saved}, the agent has {space}"
                )

    def bind(self, env, agent: str) -> None:
        """Play ``agent`` of ``env``: check its spaces against the network's. A network
        trained on padded observations (agents of several roles, ``pad=True``) reads this
        agent's observation padded as in training, its role named."""
        if not self.data.get("padded"):
            self.check(env.observation_space(agent), env.action_space(agent))
            return
        from flatland_ma.envs.padding import Padding

        padding = Padding.of(env)
        space = env.observation_space(agent) if padding is None else padding.space
        self.check(space, env.action_space(agent))
        if padding is not None:
            self._padding = (padding, env.possible_agents.index(agent))

    def act(self, observation):
        """One agent's action: an int, or an array for a ``MultiDiscrete`` space."""
        if self._padding is not None:
            padding, index = self._padding
            observation = padding.pad(index, observation)
        if isinstance(observation, dict):
            batch = {key: np.asarray(value)[None] for key, value in observation.items()}
        else:
            batch = np.asarray(observation)[None]
        action = self.act_batch(batch)[0]
        return int(action) if np.ndim(action) == 0 else action

    def act_batch(self, observations) -> np.ndarray:
        """One action per row of ``observations`` (an array, or a dict of arrays for a
        ``Dict`` space): shape (batch,) for a ``Discrete`` space, (batch, components) for
        a ``MultiDiscrete`` one."""
        import torch

        if isinstance(observations, dict):
            inputs = {k: torch.as_tensor(v, dtype=torch.float32) for k, v in observations.items()}
        else:
            inputs = torch.as_tensor(observations, dtype=torch.float32)
        with torch.inference_mode():
            logits = self.program(inputs).double().numpy()
        sizes = self.data.get("action_sizes") or [logits.shape[1]]
        parts = np.split(logits, np.cumsum(sizes)[:-1], axis=1)
        actions = np.stack([self._choose(part) for part in parts], axis=1)
        multi = str(self.data["action_space"]).startswith("MultiDiscrete")
        return actions if multi else actions[:, 0]

    def _choose(self, logits: np.ndarray) -> np.ndarray:
        if self.greedy:
            return logits.argmax(axis=1)
        p = np.exp(logits - logits.max(axis=1, keepdims=True))
        cumulative = (p / p.sum(axis=1, keepdims=True)).cumsum(axis=1)
        draws = self.rng.random((len(p), 1))
        return np.minimum((cumulative < draws).sum(axis=1), p.shape[1] - 1)
