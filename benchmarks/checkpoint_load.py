"""Load time of a PPO checkpoint on fruits_poisons: the data-only format (safetensors
weights and a JSON description, the network rebuilt by flatland_ma.policies.networks)
beside the old one (a torch.save dict whose program torch.export.load unpickles), in one
process on one machine, loads interleaved; the median of ``--repeats`` loads each.

    python benchmarks/checkpoint_load.py [--repeats 20]
"""

from __future__ import annotations

import argparse
import io
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import flatland_ma  # noqa: E402
from baselines.networks import Agent  # noqa: E402
from flatland_ma.policies.checkpoint import load_checkpoint, write_checkpoint  # noqa: E402
from tests.checkpoint_helpers import exported, write_old_checkpoint  # noqa: E402


def load_old(path: Path):
    """What version 1's CheckpointPolicy did: the dict, then the exported program."""
    data = torch.load(path, map_location="cpu", weights_only=True)
    return torch.export.load(io.BytesIO(data["program"])).module()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=20)
    repeats = parser.parse_args().repeats
    torch.set_num_threads(1)
    env = flatland_ma.parallel_env("fruits_poisons")
    observations, _ = env.reset(seed=0)
    space, actions = env.observation_space("agent_0"), env.action_space("agent_0")
    agent = Agent(space, actions)  # the baseline's defaults: strided trunk, 128 units
    optimizer = torch.optim.Adam(agent.parameters())
    folder = Path(tempfile.mkdtemp())
    new = write_checkpoint(
        folder / "seed_0.safetensors",
        agent,
        scenario="fruits_poisons",
        observation_space=space,
        action_space=actions,
        optimizer=optimizer.state_dict(),
    )

    class Logits(torch.nn.Module):
        def __init__(self, network):
            super().__init__()
            self.network = network

        def forward(self, observation):
            return self.network(observation)

    old = write_old_checkpoint(
        folder / "seed_0.pt",
        exported(Logits(agent), observations["agent_0"][None]),
        scenario="fruits_poisons",
        observation_space=str(space),
        action_space=str(actions),
        action_sizes=[3],
        model=agent.state_dict(),
        optimizer=optimizer.state_dict(),
    )
    load_old(old), load_checkpoint(new)  # warm both paths' imports and caches
    times: dict[str, list[float]] = {"old (torch.export.load)": [], "new (safetensors)": []}
    for _ in range(repeats):
        for name, load, path in (
            ("old (torch.export.load)", load_old, old),
            ("new (safetensors)", load_checkpoint, new),
        ):
            start = time.perf_counter()
            load(path)
            times[name].append(time.perf_counter() - start)
    load_average = os.getloadavg()[0]
    print(f"PPO fruits_poisons checkpoint, {repeats} loads each, load average {load_average:.1f}")
    for name, path in (("old (torch.export.load)", old), ("new (safetensors)", new)):
        ms = [1000 * t for t in times[name]]
        size = path.stat().st_size / 1024
        print(
            f"{name:24} {size:7.0f} KiB  median {statistics.median(ms):7.1f} ms"
            f"  (min {min(ms):.1f}, max {max(ms):.1f})"
        )


if __name__ == "__main__":
    main()
