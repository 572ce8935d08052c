"""PPO living a never-ending stream (``scenarios/streams/never_ending.yaml``): every world
one endless episode whose item values and places drift, no task boundaries, no resets.

It is ``baselines.lifelong``'s learner (``finetune``: PPO with a constant learning rate,
on the stream's batched env) for a budget of agent-steps, without its evaluation blocks,
which play whole episodes and so would never end here. The final network is written as a
checkpoint, which the benchmark then scores as it scores every other method on the stream:
its first ``never_ending_steps`` steps on held-out seeds (``baselines.benchmark``).

    python -m baselines.benchmark --only never_ending --methods ppo
"""

from __future__ import annotations

from pathlib import Path

import torch

from baselines import lifelong
from baselines.common import seed_everything
from flatland_ma.policies.checkpoint import SUFFIX, write_checkpoint


class NoBlocks:
    """An evaluator that evaluates nothing (``lifelong.train`` calls it between rollouts)."""

    def block(self, agent, step: int) -> dict[int, float]:
        return {}

    def close(self) -> None:
        pass


def train(name: str, seed: int, budget: int, options: dict, runs: Path) -> tuple[str, int]:
    """PPO through never-ending stream ``name`` for ``budget`` agent-steps, with PPO's
    ``options``: (the final checkpoint's path, agent-steps trained)."""
    from flatland_ma.lifelong import StreamBatchedEnv, load_stream

    stream = load_stream(name)
    if not stream.never_ending:
        raise ValueError(f"{name}: not a never-ending stream")
    args = lifelong.Args(stream=name, method="finetune", seed=seed, tensorboard=False, **options)
    seed_everything(args.seed)
    torch.set_num_threads(args.torch_threads)
    env = StreamBatchedEnv(stream, num_worlds=args.num_envs, copy=False)
    try:
        agent, optimizer = lifelong.new_agent(args, env)
        steps = lifelong.train(args, agent, optimizer, env, budget, NoBlocks(), every=budget + 1)
        path = runs / name / "ppo" / f"seed_{seed}{SUFFIX}"
        path.parent.mkdir(parents=True, exist_ok=True)
        write_checkpoint(
            path,
            agent,
            scenario=str(stream.task_labels[0]),
            observation_space=env.single_observation_space,
            action_space=env.single_action_space,
            optimizer=optimizer.state_dict(),
            extra={"algorithm": "ppo", "trained_with": ["self"], "agent_steps": steps},
        )
    finally:
        env.close()
    return str(path), steps
