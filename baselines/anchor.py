"""A pull towards the policy a run started from (``--anchor W``, with ``--init-from``).

PPO started from a taught policy (an imitator of ``baselines.benchmark.imitate``) can
undo it: on ``maze_goal`` its updates took the wall follower's imitator from 8 goals in 10
episodes to 1 within 300k agent-steps, and as fast with every reward zeroed, where the
advantages carry nothing but noise (docs/results.md, "PPO undoes a taught policy"). The
anchor adds to each minibatch's loss the KL divergence from the starting policy's action
distribution to the network's, summed over the action's heads and averaged over the rows:

    L_anchor = w * mean_rows sum_heads KL(pi_start(.|s) || pi(.|s))

so that the policy moves from where it started only as far as the returns pay for
(kickstarting: Schmitt et al., "Kickstarting Deep Reinforcement Learning", 2018, who fade
the weight; ``--anchor-fade F`` lowers it linearly to 0 over the first fraction F of the
run's updates, 0 holds it throughout). The starting policy is read again from the
``--init-from`` file, so a resumed run is pulled towards the same policy. Feed-forward
policies only (no ``--memory``, ``--frames``), and not with the channel's biases.
"""

from __future__ import annotations

import copy

import torch

from baselines.ppo_resume import start_from


class Anchor:
    """The pull towards ``reference`` (a frozen network of the run's own shape) with weight
    ``weight``, fading to 0 over the first ``fade_updates`` updates (0: held), from update
    ``done`` on (a resumed run's); ``calls_per_update``: the minibatches of one update."""

    def __init__(
        self, reference, weight: float, fade_updates: int, calls_per_update: int, done: int = 0
    ):
        self.reference = reference.eval().requires_grad_(False)
        self.weight, self.fade_updates = weight, fade_updates
        self.calls_per_update = calls_per_update
        self.calls = done * calls_per_update
        """Minibatches pulled so far (the update they belong to sets the weight)."""

    def weight_now(self) -> float:
        """The weight at the update under way."""
        if not self.fade_updates:
            return self.weight
        update = self.calls // self.calls_per_update
        return self.weight * max(0.0, 1.0 - update / self.fade_updates)

    def act(self, agent, observation, action: torch.Tensor, state, index: torch.Tensor):
        """``agent.act(observation, action, state)``'s result, the anchor's loss and its
        KL (``losses/anchor_kl``), the features read once."""
        weight = self.weight_now()
        self.calls += 1
        h = agent.features(observation)
        decided = agent.decide(h, action, state)
        with torch.no_grad():
            target = self.reference.actor(self.reference.features(observation))
        kl = divergence(target, agent.actor(h), agent.sizes)
        return decided, weight * kl, {"losses/anchor_kl": kl.detach()}


def divergence(target: torch.Tensor, logits: torch.Tensor, sizes) -> torch.Tensor:
    """KL(p_target || p) summed over the heads (``sizes``: each head's choices, the
    logits joined along the last axis), averaged over the rows."""
    total = logits.new_zeros(())
    for ref, own in zip(target.split(sizes, -1), logits.split(sizes, -1)):
        log_ref, log_own = ref.log_softmax(-1), own.log_softmax(-1)
        total = total + (log_ref.exp() * (log_ref - log_own)).sum(-1).mean()
    return total


def anchor(args, agent, iterations: int, resumed=None) -> Anchor | None:
    """The run's ``Anchor`` over its ``iterations`` updates (None without ``--anchor``),
    its reference read from ``args.init_from``, from the update a ``resumed`` run
    (``baselines.ppo_resume.Resumed``) stood at; ``ValueError`` for options it does not
    go with."""
    if not args.anchor:
        return None
    if args.anchor < 0 or not 0.0 <= args.anchor_fade <= 1.0:
        raise ValueError(
            f"--anchor {args.anchor} --anchor-fade {args.anchor_fade}: "
            "a weight >= 0 and a fraction of the run in [0, 1]"
        )
    if not args.init_from:
        raise ValueError("--anchor pulls towards the policy of --init-from: give one")
    if agent.remembers:
        raise ValueError("--anchor pulls feed-forward policies (no --memory, --frames)")
    if args.listening or args.signalling:
        raise ValueError("--anchor is not combined with --listening or --signalling")
    reference = copy.deepcopy(agent)
    start_from(reference, args.init_from)
    fade = max(1, round(args.anchor_fade * iterations)) if args.anchor_fade else 0
    done = 0 if resumed is None else resumed.update
    calls = args.update_epochs * args.num_minibatches
    return Anchor(reference, args.anchor, fade, calls, done)
