"""VMAS on the CPU: the paper's room as VMAS draws it, each agent with a 64-ray lidar.

A square room (4 walls), 4 obstacles and 20 round items, 1 or 4 agents; every lidar ray
is cast against every collidable entity, as the flatland_ma camera's rays are. Prints JSON:
world steps/s and agent steps/s for each number of worlds, at 1 torch thread and at every
core (``--threads`` to choose). Run it in its own environment (see README.md in this folder).

    python vmas_lidar.py --worlds 1 16 256 1024 --agents 1 4 --seconds 3
"""

from __future__ import annotations

import argparse
import json
import os
import time

import torch
import vmas
from vmas.simulator.core import Agent, Box, Landmark, Line, Sphere, World
from vmas.simulator.scenario import BaseScenario
from vmas.simulator.sensors import Lidar


class Room(BaseScenario):
    def make_world(self, batch_dim: int, device, **kwargs):
        self.n_agents = kwargs.pop("n_agents", 1)
        rays = kwargs.pop("rays", 64)
        world = World(batch_dim, device, x_semidim=1.0, y_semidim=1.0)
        for i in range(self.n_agents):
            world.add_agent(
                Agent(
                    name=f"agent_{i}",
                    shape=Sphere(0.05),
                    sensors=[Lidar(world, n_rays=rays, max_range=2.0)],
                )
            )
        for k in range(4):
            world.add_landmark(Landmark(f"wall_{k}", collide=True, shape=Line(length=2.0)))
        for k in range(4):
            world.add_landmark(Landmark(f"obstacle_{k}", collide=True, shape=Box(0.2, 0.2)))
        for k in range(20):
            world.add_landmark(Landmark(f"item_{k}", collide=True, shape=Sphere(0.03)))
        return world

    def reset_world_at(self, env_index=None):
        walls = self.world.landmarks[:4]
        places = [
            (0.0, 1.0, 0.0),
            (0.0, -1.0, 0.0),
            (1.0, 0.0, torch.pi / 2),
            (-1.0, 0.0, torch.pi / 2),
        ]
        for wall, (x, y, angle) in zip(walls, places):
            wall.set_pos(torch.tensor([x, y]), batch_index=env_index)
            wall.set_rot(torch.tensor([angle]), batch_index=env_index)
        for entity in self.world.agents + self.world.landmarks[4:]:
            position = torch.rand(self.world.batch_dim, 2) * 1.6 - 0.8
            entity.set_pos(
                position if env_index is None else position[env_index], batch_index=env_index
            )

    def observation(self, agent):
        return torch.cat([agent.state.pos, agent.state.vel, agent.sensors[0].measure()], dim=-1)

    def reward(self, agent):
        return torch.zeros(self.world.batch_dim)


def rate(worlds: int, agents: int, seconds: float) -> float:
    env = vmas.make_env(Room(), num_envs=worlds, device="cpu", continuous_actions=True,
                        seed=0, n_agents=agents)  # fmt: skip
    env.reset()
    actions = [torch.rand(worlds, 2) * 2 - 1 for _ in range(agents)]
    env.step(actions)
    steps, start = 0, time.perf_counter()
    while steps < 3 or time.perf_counter() - start < seconds:
        env.step(actions)
        steps += 1
    return steps * worlds / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--worlds", type=int, nargs="+", default=[1, 16, 256, 1024])
    parser.add_argument("--agents", type=int, nargs="+", default=[1, 4])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--threads", type=int, nargs="+", default=sorted({1, os.cpu_count() or 1}))
    args = parser.parse_args()
    rows = []
    for threads in args.threads:
        torch.set_num_threads(threads)
        for agents in args.agents:
            for worlds in args.worlds:
                r = rate(worlds, agents, args.seconds)
                rows.append({"system": f"vmas {vmas.__version__}", "threads": threads,
                             "agents": agents, "worlds": worlds, "world_steps_per_s": r,
                             "agent_steps_per_s": r * agents})  # fmt: skip
                print(json.dumps(rows[-1]), flush=True)


if __name__ == "__main__":
    main()
