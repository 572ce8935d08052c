"""Shared-parameter PPO through Ray RLlib, for runs that outgrow one machine.

Every agent of ``fruits_poisons_multi`` (``--scenario``) plays the one policy "shared". The
env reaches RLlib through its PettingZoo wrapper with each observation flattened by
``flatland_ma.envs.flatten.FlattenObservations`` (RLlib's default networks take 1-D
observations), so no connector is needed. The env is registered with a creator that
imports flatland_ma, so remote env runners find it; Gymnasium ids used in remote workers
must name the module: ``gymnasium.make("flatland_ma:flatland_ma/FruitsPoisons-v0")``.

Starts a local Ray instance, or joins a cluster with ``--address``. Ray pins its own
gymnasium: run it in its own environment (``make test-rllib`` builds one, .venv-rllib).

    python -m baselines.rllib_ppo --iterations 50 --num-env-runners 2
"""

from __future__ import annotations

import argparse
import time

ENV_NAME = "flatland_ma_parallel"


def make_env(config: dict):
    """The env of one env runner: the scenario's parallel env, observations flattened."""
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    import flatland_ma
    from flatland_ma.envs.flatten import FlattenObservations

    return ParallelPettingZooEnv(FlattenObservations(flatland_ma.parallel_env(config["scenario"])))


def shared_policy(agent_id, episode, **kwargs) -> str:
    return "shared"


def build(args: argparse.Namespace):
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.tune.registry import register_env

    register_env(ENV_NAME, make_env)
    config = (
        PPOConfig()
        .environment(ENV_NAME, env_config={"scenario": args.scenario})
        .multi_agent(policies={"shared"}, policy_mapping_fn=shared_policy)
        .env_runners(num_env_runners=args.num_env_runners, rollout_fragment_length=args.fragment)
        .training(
            train_batch_size_per_learner=args.batch,
            minibatch_size=max(1, args.batch // 4),
            num_epochs=args.epochs,
            lr=args.lr,
        )
        .debugging(seed=args.seed)
    )
    return config.build_algo()


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="fruits_poisons_multi")
    parser.add_argument("--iterations", type=int, default=50, help="training iterations")
    parser.add_argument("--address", default=None, help="a Ray cluster to join (default: local)")
    parser.add_argument("--num-env-runners", type=int, default=1)
    parser.add_argument("--batch", type=int, default=4000, help="env steps per iteration")
    parser.add_argument("--fragment", type=int, default=200, help="steps per runner sample")
    parser.add_argument("--epochs", type=int, default=4)
    parser.add_argument("--lr", type=float, default=3e-4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--checkpoint", default=None, help="save the trained algorithm here")
    args = parser.parse_args(argv)

    import ray

    ray.init(address=args.address, include_dashboard=False, ignore_reinit_error=True)
    try:
        algo = build(args)
        results = []
        for iteration in range(1, args.iterations + 1):
            start = time.perf_counter()
            result = algo.train()
            seconds = time.perf_counter() - start
            runners = result.get("env_runners", {})
            agent_steps = runners.get("num_agent_steps_sampled", {})
            total = sum(agent_steps.values()) if isinstance(agent_steps, dict) else agent_steps
            mean = runners.get("episode_return_mean", float("nan"))
            print(
                f"iteration {iteration}: return mean {mean:.1f} "
                f"env steps {runners.get('num_env_steps_sampled', 0)} "
                f"agent-steps/s {total / seconds:,.0f}",
                flush=True,
            )
            results.append(result)
        if args.checkpoint:
            algo.save_to_path(args.checkpoint)
        algo.stop()
        return results
    finally:
        ray.shutdown()


if __name__ == "__main__":
    main()
