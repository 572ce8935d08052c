"""PPO living through a task stream, evaluated on every task as it goes.

Three learners, one per ``--method``, each with the batched PPO of ``baselines.ppo`` (its
network, rollouts and update; a constant learning rate, as a life has no end to anneal
to):

- ``finetune``: the naive learner. It trains on whatever the stream gives, and nothing
  keeps what it learnt before.
- ``replay``: behaviour cloning from a replay buffer (after CLEAR, Rolnick et al. 2019,
  and the behaviour-cloning learner of Wołczyk et al. 2022). When a task ends, the
  learner keeps ``--replay-size`` of the observations it saw in it, with its own policy's
  logits and values on them at that moment. Every minibatch of every later update adds
  ``--clone-coef`` times the KL divergence from those kept logits to the current policy's,
  and the squared error to the kept values, on a minibatch drawn from the buffer. It
  learns where the tasks change from ``infos["task"]``: a learner that uses the
  boundaries, as EWC-style methods do.
- ``reference``: a fresh learner on each task alone, for as many agent-steps as one of its
  segments in the stream: the baseline of forward transfer.

Every ``eval_every`` agent-steps (the stream's, or ``--eval-every``), and at the start and
the end, an evaluation block plays ``eval_episodes`` episodes of every task (the reference
learner: of its own task) with the current policy, on worlds seeded apart from training,
and writes one row per task to ``<out>/<method>/seed_<seed>/evaluations.csv``
(``step,task,episodes,mean_return``). ``<out>/stream.json`` holds the stream's tasks, its
segments and random play's mean return on each task; ``flatland-ma lifelong report <out>``
reads them all.

    python -m baselines.lifelong --stream cross_objective --method finetune --seed 0
"""

from __future__ import annotations

import csv
import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import torch
import tyro
from torch.nn import functional as F
from torch.utils._pytree import tree_map

from baselines.common import input_channels, seed_everything
from baselines.networks import Agent
from baselines.ppo import Args as PPOArgs
from baselines.ppo_learner import Rollout

EVALUATION_SEED = 1_000_000
"""Evaluation worlds are seeded from here on, apart from every training world."""


@dataclass
class Args(PPOArgs):
    stream: str = "cross_objective"
    """A shipped stream's name or a stream file's path."""
    method: Literal["finetune", "replay", "reference"] = "finetune"
    """The learner (see the module's docstring)."""
    out: str = ""
    """The run folder; empty means runs/lifelong/<stream>."""
    scale: float = 1.0
    """Every task's length times this (short runs for tests)."""
    eval_every: int = 0
    """Agent-steps between evaluation blocks; 0: the stream's."""
    eval_episodes: int = 0
    """Episodes per task per block; 0: the stream's."""
    replay_size: int = 4096
    """Observations kept from each task (``replay``)."""
    clone_coef: float = 1.0
    """Weight of the behaviour-cloning loss on the kept observations (``replay``)."""
    anneal_lr: bool = False
    """A constant learning rate through the stream."""
    num_envs: int = 8


# -- evaluation ------------------------------------------------------------------------


def play(agent: Agent | None, env, seed: int) -> float:
    """The mean return of the first episode of each world of a batched ``env`` (every
    agent it drives), played by ``agent`` (random play when None)."""
    observation, infos = env.reset(seed=seed)
    m = env.agents_per_world
    returns, done_world = np.zeros(env.num_slots), np.zeros(env.num_worlds, bool)
    finished = np.zeros(env.num_slots, bool)
    while not done_world.all():
        if agent is None:
            action = np.stack([env.single_action_space.sample() for _ in range(env.num_slots)])
        else:
            with torch.inference_mode():
                action, _, _, _ = agent.act(tree_map(torch.from_numpy, observation))
            action = action.numpy()
            if action.shape[1] == 1:
                action = action[:, 0]
        observation, reward, terminated, truncated, infos = env.step(action)
        counting = ~finished & ~np.repeat(done_world, m)
        returns[counting] += reward[counting]
        finished |= (terminated | truncated) & counting
        for w in range(env.num_worlds):
            own = slice(w * m, (w + 1) * m)
            if (finished[own] | ~infos["active"][own]).all():
                done_world[w] = True
    return float(returns.sum() / env.num_worlds / m)


class Evaluator:
    """Evaluation blocks: each of ``tasks``' mean return over ``episodes`` episodes (one
    per world of a batched env of the task), on worlds seeded apart from training, added
    as rows of the CSV file at ``path`` (which gets its header if it is new)."""

    def __init__(self, stream, tasks: list[int], episodes: int, path: Path):
        from flatland_ma.lifelong import task_batched

        self.tasks, self.episodes = tasks, episodes
        self.envs = {i: task_batched(stream, i, episodes, parallel=False) for i in tasks}
        path.parent.mkdir(parents=True, exist_ok=True)
        new = not path.exists()
        self.file = open(path, "a", newline="")
        self.writer = csv.writer(self.file)
        if new:
            self.writer.writerow(["step", "task", "episodes", "mean_return"])

    def block(self, agent: Agent, step: int) -> dict[int, float]:
        scores = {}
        for i in self.tasks:
            scores[i] = play(agent, self.envs[i], EVALUATION_SEED + 1000 * i)
            self.writer.writerow([step, i, self.episodes, f"{scores[i]:.6g}"])
        self.file.flush()
        print(f"step={step} eval " + " ".join(f"{i}:{s:.1f}" for i, s in scores.items()))
        return scores

    def close(self) -> None:
        self.file.close()
        for env in self.envs.values():
            env.close()


# -- behaviour cloning from a replay buffer ----------------------------------------------


class CloningReplay:
    """Per finished task: observations the learner saw in it, with its policy's logits
    and values on them when the task ended."""

    def __init__(self, size: int, coef: float, generator: torch.Generator):
        self.size, self.coef, self.generator = size, coef, generator
        self.kept: dict[int, tuple] = {}
        self.seen: list = []
        """This task's observations so far (rollouts' acting entries), newest last."""

    def add_rollout(self, rollout: Rollout) -> None:
        used = rollout.acting.reshape(-1).nonzero().squeeze(1)
        flat = tree_map(lambda x: x.reshape(-1, *x.shape[2:])[used].clone(), rollout.observations)
        self.seen.append(flat)
        total = sum(len(tree_leaf(x)) for x in self.seen)
        while self.seen and total - len(tree_leaf(self.seen[0])) >= self.size:
            total -= len(tree_leaf(self.seen.pop(0)))

    def end_task(self, task: int, agent: Agent) -> None:
        """Keep ``size`` of this task's observations at random, with the policy's outputs."""
        if not self.seen:
            return
        joined = tree_map(lambda *xs: torch.cat(xs), *self.seen)
        n = len(tree_leaf(joined))
        index = torch.randperm(n, generator=self.generator)[: self.size]
        observations = tree_map(lambda x: x[index], joined)
        with torch.inference_mode():
            logits, values = agent(observations), agent.value(observations)
        self.kept[task] = (observations, logits.clone(), values.clone())
        self.seen = []

    def penalty(self, agent: Agent, batch: int):
        """The cloning loss on a minibatch of ``batch`` kept observations, drawn evenly
        over the kept tasks; None while nothing is kept."""
        if not self.kept:
            return None
        parts = [self._draw(kept, max(1, batch // len(self.kept))) for kept in self.kept.values()]
        observations = tree_map(lambda *xs: torch.cat(xs), *[p[0] for p in parts])
        old_logits = torch.cat([p[1] for p in parts])
        old_values = torch.cat([p[2] for p in parts])

        def loss() -> torch.Tensor:
            logits = agent(observations)
            kl = 0.0
            for old, new in zip(
                old_logits.split(agent.sizes, dim=-1), logits.split(agent.sizes, dim=-1)
            ):
                kl = kl + F.kl_div(
                    F.log_softmax(new, -1),
                    F.log_softmax(old, -1),
                    log_target=True,
                    reduction="batchmean",
                )
            value = (agent.value(observations) - old_values).square().mean()
            return self.coef * (kl + 0.5 * value)

        return loss

    def _draw(self, kept, n: int):
        observations, logits, values = kept
        index = torch.randint(len(logits), (n,), generator=self.generator)
        return tree_map(lambda x: x[index], observations), logits[index], values[index]


def tree_leaf(x) -> torch.Tensor:
    return x if isinstance(x, torch.Tensor) else next(iter(x.values()))


# -- the runs ---------------------------------------------------------------------------


def new_agent(args: Args, env) -> tuple[Agent, torch.optim.Optimizer]:
    agent = Agent(
        env.single_observation_space,
        env.single_action_space,
        args.hidden,
        input_channels(args.use_depth),
        args.network,
    )
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)
    return agent, optimizer


def train(args: Args, agent, optimizer, env, steps: int, evaluator, every: int, replay=None):
    """PPO on ``env`` for ``steps`` agent-steps, with evaluation blocks every ``every``."""
    observation, infos = env.reset(seed=args.seed * args.num_envs)
    rollout = Rollout(agent, env, observation, args.num_steps)
    step, next_block = 0, every
    task = [int(infos["task"][0]) if "task" in infos else 0]
    """The task of the last step: the stream's infos say it (to the replay learner)."""
    batch = max(1, rollout.steps * env.num_slots // args.num_minibatches)

    def after_step(reward, terminated, done, infos, acted: int) -> None:
        nonlocal step
        step += acted
        if "task" in infos:
            task.append(int(infos["task"][0]))

    evaluator.block(agent, 0)
    while step < steps:
        before, task[:] = task[-1], task[-1:]
        observation = rollout.collect(agent, env, observation, args.reward_scale, after_step)
        penalty = None
        if replay is not None:
            replay.add_rollout(rollout)
            penalty = replay.penalty(agent, batch)
        rollout.learn(agent, optimizer, args, penalty=penalty)
        if replay is not None and task[-1] != before:  # the task changed in this rollout
            replay.end_task(before, agent)
        if step >= next_block and step < steps:
            evaluator.block(agent, step)
            next_block += every
    evaluator.block(agent, step)
    return step


TAKEN = frozenset(
    {
        "seed", "num_envs", "num_steps", "learning_rate", "anneal_lr", "gamma", "gae_lambda",
        "num_minibatches", "update_epochs", "clip_coef", "ent_coef", "vf_coef",
        "max_grad_norm", "reward_scale", "hidden", "network", "use_depth", "torch_threads",
        "tensorboard",
    }
)  # fmt: skip
"""The options of ``baselines.ppo`` a life through a stream takes (it writes no
TensorBoard events, so that one changes nothing); ``anneal_lr`` only at its default here,
off: a life has no end to anneal to."""


def untaken(args: Args) -> str:
    """The options of ``baselines.ppo`` set on ``args`` that a life does not take, as
    given on the command line (empty if none): every one away from this learner's default
    (``anneal_lr`` on too)."""
    defaults = Args()
    wrong = [
        f.name
        for f in dataclasses.fields(PPOArgs)
        if (f.name not in TAKEN or f.name == "anneal_lr")
        and getattr(args, f.name) != getattr(defaults, f.name)
    ]
    return ", ".join("--" + name.replace("_", "-") for name in wrong)


def main(args: Args) -> dict:
    from flatland_ma.lifelong import StreamBatchedEnv, load_stream, task_batched

    wrong = untaken(args)
    if wrong:
        raise SystemExit(f"baselines.lifelong does not take {wrong} (options of baselines.ppo)")
    seed_everything(args.seed)
    torch.set_num_threads(args.torch_threads)
    stream = load_stream(args.stream).scaled(args.scale)
    out = Path(args.out or f"runs/lifelong/{Path(args.stream).stem}")
    every = args.eval_every or int(stream.eval.every * args.scale)
    episodes = args.eval_episodes or stream.eval.episodes
    segments = stream.segments()
    labels = list(stream.task_labels)
    write_stream(out, stream, labels, segments, every, episodes)
    evaluations = out / args.method / f"seed_{args.seed}" / "evaluations.csv"
    evaluations.unlink(missing_ok=True)
    start = time.perf_counter()
    if args.method == "reference":
        done = 0
        for i in range(len(labels)):  # each task alone, from scratch, for one segment
            length = next(b - a for j, a, b in segments if j == i)
            env = task_batched(stream, i, args.num_envs)
            agent, optimizer = new_agent(args, env)
            evaluator = Evaluator(stream, [i], episodes, evaluations)
            done += train(args, agent, optimizer, env, length, evaluator, every)
            evaluator.close()
            env.close()
    else:
        env = StreamBatchedEnv(stream, num_worlds=args.num_envs, copy=False)
        agent, optimizer = new_agent(args, env)
        replay = None
        if args.method == "replay":
            generator = torch.Generator().manual_seed(args.seed)
            replay = CloningReplay(args.replay_size, args.clone_coef, generator)
        evaluator = Evaluator(stream, list(range(len(labels))), episodes, evaluations)
        done = train(args, agent, optimizer, env, segments[-1][2], evaluator, every, replay)
        evaluator.close()
        env.close()
    seconds = time.perf_counter() - start
    summary = {"method": args.method, "seed": args.seed, "agent_steps": done, "seconds": seconds}
    (evaluations.parent / "run.json").write_text(
        json.dumps({**summary, "args": vars(args)}, indent=1)
    )
    print(f"done: {done} agent-steps in {seconds:.0f} s")
    return summary


def write_stream(out: Path, stream, labels, segments, every: int, episodes: int) -> None:
    """``stream.json``: the tasks, the life's segments, and random play's mean return on
    each task (over 4 times the evaluation's episodes)."""
    from flatland_ma.lifelong import task_batched

    path = out / "stream.json"
    if path.exists():
        return
    random = []
    for i in range(len(labels)):
        env = task_batched(stream, i, 4 * episodes, parallel=False)
        env.single_action_space.seed(0)
        random.append(play(None, env, EVALUATION_SEED + 1000 * i))
        env.close()
    out.mkdir(parents=True, exist_ok=True)
    data = {
        "stream": stream.name if hasattr(stream, "name") else str(out.name),
        "tasks": labels,
        "segments": [list(s) for s in segments],
        "random": random,
        "eval_every": every,
        "eval_episodes": episodes,
    }
    part = path.with_suffix(".part")
    part.write_text(json.dumps(data, indent=1))
    part.replace(path)


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__))
