"""An exploration bonus from the observations alone: random network distillation (RND;
Burda, Edwards, Storkey and Klimov, "Exploration by Random Network Distillation", 2018).

A fixed network of random weights (the target) maps each observation to a vector; a
second network (the predictor) learns to map observations to the same vectors, trained on
what the agents saw. Its error is small on observations like those seen often and large on
new ones, and that error, scaled, is added to the reward (``baselines.ppo --novelty W``):

    bonus_t = W * |f(o_{t+1}) - f_hat(o_{t+1})|^2 / std(R_int)

with ``o_{t+1}`` what step t returned, each input normalised by running moments of the
observations and clipped to [-5, 5] (as the paper's), and the error divided by a running
standard deviation of its discounted sum per slot, ``R_int``, so that ``W`` keeps one
meaning while the error shrinks. The bonus joins the task's (scaled) reward in the one
value of ``baselines.ppo`` and ends with each episode, where the paper keeps a second,
non-episodic value head: simpler, and what the tasks here, all episodic, need. Both
networks read every leaf of the observation flattened (fully connected layers: the
observations here are rays, lidar and small maps, not Atari frames). The predictor trains
on each rollout's observations after their bonus is measured, with an optimiser of its
own; none of this is in the policy's checkpoint but the run's, to go on with it
(``state`` and ``load``).
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torch import nn
from torch.utils._pytree import tree_leaves


class Moments:
    """Running mean and variance over batches of rows (Chan, Golub and LeVeque's update)."""

    def __init__(self, width: int):
        self.mean, self.var, self.count = np.zeros(width), np.ones(width), 1e-4

    def update(self, rows: np.ndarray) -> None:
        if len(rows) == 0:
            return
        mean, var, n = rows.mean(0), rows.var(0), len(rows)
        delta, total = mean - self.mean, self.count + n
        self.mean = self.mean + delta * n / total
        self.var = (self.var * self.count + var * n + delta**2 * self.count * n / total) / total
        self.count = total

    def state(self) -> dict:
        return {
            "mean": torch.from_numpy(self.mean),
            "var": torch.from_numpy(self.var),
            "count": float(self.count),
        }

    def load(self, state: dict) -> None:
        self.mean = state["mean"].double().numpy().copy()
        self.var = state["var"].double().numpy().copy()
        self.count = float(state["count"])


def _mlp(sizes: list[int]) -> nn.Sequential:
    layers: list[nn.Module] = []
    for i, (n_in, n_out) in enumerate(zip(sizes, sizes[1:])):
        layer = nn.Linear(n_in, n_out)
        nn.init.orthogonal_(layer.weight, math.sqrt(2))
        nn.init.zeros_(layer.bias)
        layers += [layer] if i == len(sizes) - 2 else [layer, nn.LeakyReLU()]
    return nn.Sequential(*layers)


class Novelty:
    """RND's bonus for the rollouts of one run: ``sample``, the batched env's observation
    (a tree of arrays, one row per slot), fixes the inputs; ``weight`` is ``W`` above."""

    def __init__(
        self,
        sample,
        slots: int,
        weight: float,
        seed: int,
        *,
        gamma: float = 0.99,
        epochs: int = 4,
        minibatches: int = 4,
        learning_rate: float = 1e-4,
        width: int = 256,
        size: int = 64,
    ):
        if not (isinstance(weight, (int, float)) and math.isfinite(weight) and weight > 0):
            raise ValueError(f"--novelty: a bonus weight above 0, not {weight!r}")
        self.weight, self.gamma = float(weight), gamma
        self.epochs, self.minibatches = epochs, minibatches
        self.features = sum(int(np.prod(np.shape(x)[1:])) for x in tree_leaves(sample))
        with torch.random.fork_rng(devices=[]):  # the run's own draws stay as they were
            torch.manual_seed(seed)
            self.target = _mlp([self.features, width, size]).requires_grad_(False)
            self.predictor = _mlp([self.features, width, width, size])
        self.optimizer = torch.optim.Adam(self.predictor.parameters(), lr=learning_rate)
        self.generator = torch.Generator().manual_seed(seed)
        self.inputs, self.returns = Moments(self.features), Moments(1)
        self.running = np.zeros(slots)
        """Each slot's discounted sum of its error, across episodes (the paper's)."""
        self.stats: dict[str, float] = {}
        """The last rollout's mean bonus (as learnt from, before W) and predictor loss."""

    def inputs_of(self, observations, final) -> torch.Tensor:
        """What each step of a rollout returned, ``(T, slots, features)`` as float32: the
        observations of steps 1..T-1 and ``final``, what the last step returned."""
        leaves = []
        for x, last in zip(tree_leaves(observations), tree_leaves(final)):
            following = torch.cat([x[1:], torch.as_tensor(np.asarray(last))[None]])
            leaves.append(following.reshape(*x.shape[:2], -1).float())
        return torch.cat(leaves, dim=2)

    def normalised(self, x: torch.Tensor) -> torch.Tensor:
        mean = torch.from_numpy(self.inputs.mean).float()
        std = torch.from_numpy(np.sqrt(self.inputs.var + 1e-8)).float()
        return ((x - mean) / std).clamp_(-5.0, 5.0)

    def error(self, x: torch.Tensor) -> torch.Tensor:
        """The predictor's squared error per row (mean over the target's outputs)."""
        return (self.predictor(x) - self.target(x)).pow(2).mean(-1)

    def bonus(self, observations, final, acting: torch.Tensor) -> torch.Tensor:
        """The bonus of each step of a rollout (``(T, slots)``, 0 where the env did not use
        the slot's action), then the predictor trained on those steps."""
        steps, slots = acting.shape
        if len(self.running) != slots:  # a curriculum's stage of other worlds
            self.running = np.zeros(slots)
        x = self.inputs_of(observations, final).reshape(steps * slots, -1)
        used = acting.reshape(-1)
        self.inputs.update(x[used].double().numpy())
        x = self.normalised(x)
        with torch.no_grad():
            error = self.error(x).reshape(steps, slots).numpy().astype(np.float64)
        sums = np.empty_like(error)
        for t in range(steps):
            self.running = self.running * self.gamma + error[t]
            sums[t] = self.running
        self.returns.update(sums.reshape(-1, 1)[used.numpy()])
        bonus = torch.from_numpy(error / math.sqrt(self.returns.var[0] + 1e-8)).float()
        bonus = bonus * acting
        loss = self.train(x[used])
        self.stats = {
            "novelty/bonus": float(bonus[acting].mean()) if used.any() else 0.0,
            "novelty/predictor_loss": loss,
        }
        return self.weight * bonus

    def train(self, x: torch.Tensor) -> float:
        """The predictor's epochs over rows ``x``; its last minibatch's loss."""
        loss = torch.zeros(())
        for _ in range(self.epochs):
            order = torch.randperm(len(x), generator=self.generator)
            for index in order.tensor_split(self.minibatches):
                if len(index) == 0:
                    continue
                loss = self.error(x[index]).mean()
                self.optimizer.zero_grad(set_to_none=True)
                loss.backward()
                self.optimizer.step()
        return float(loss.detach())

    def state(self) -> dict:
        """Everything a resumed run needs to go on with the same bonus."""
        return {
            "predictor": self.predictor.state_dict(),
            "target": self.target.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "inputs": self.inputs.state(),
            "returns": self.returns.state(),
            "running": torch.from_numpy(self.running),
            "generator": self.generator.get_state(),
        }

    def load(self, state: dict) -> None:
        self.predictor.load_state_dict(state["predictor"])
        self.target.load_state_dict(state["target"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.inputs.load(state["inputs"])
        self.returns.load(state["returns"])
        self.running = state["running"].double().numpy().copy()
        self.generator.set_state(state["generator"])


def for_run(args, env, observation, seed: int, resumed=None) -> Novelty | None:
    """The bonus of a ``baselines.ppo`` run (None without ``--novelty``): for ``env``'s
    slots, from where ``resumed`` (a ``baselines.ppo_resume.Resumed``) left it if given."""
    if not args.novelty:
        return None
    novelty = Novelty(observation, env.num_slots, args.novelty, seed)
    if resumed is not None:
        novelty.load(resumed.novelty())
    return novelty


def kept_with(optimizer_state: dict, novelty: Novelty | None) -> dict:
    """The optimiser's state as a run's checkpoint keeps it: with the bonus's under
    ``"novelty"`` if there is one (``Resumed.load`` leaves it out for the optimiser)."""
    return optimizer_state if novelty is None else {**optimizer_state, "novelty": novelty.state()}
