"""Biases towards using the channel, after Eccles et al., "Biases for Emergent
Communication in Multi-agent Reinforcement Learning" (NeurIPS 2019): terms added to PPO's
loss (``--listening W``, ``--signalling W``) that reward hearing and saying something,
whatever it means; PPO's own objective decides what.

- Listening: each row's moves should depend on what the others said. The row is read
  twice, once as heard and once with every other speaker's words changed to other words
  (each token's one-hot moved on by one word: for two words, the other one; the row's own
  words and the "heard" flags stay). The term is the moves' total variation between the
  two readings, summed over the move heads, averaged over the rows, in [0, heads]; the
  loss subtracts ``W`` times it. Eccles et al. compare with a learnt policy that hears
  nothing; changed words keep the input one the network has seen (every word is heard
  at every step), so it cannot meet the bias by telling silence from speech.
- Signalling: each agent's words should tell its situations apart: per agent of a world,
  the entropy of its words' mean distribution over the minibatch less the mean of each
  row's own, per token head, averaged over the agents (Eccles et al.'s positive
  signalling, without its target entropy; pooled over the agents, two roles that each
  always say one word of their own would meet it); the loss subtracts ``W`` times it.

Both read the minibatch's observations through the network once: the encodings are shared,
and only the messages' part and the layers after it are computed again. Feed-forward
policies only (no ``--memory``, no ``--frames``).
"""

from __future__ import annotations

import torch

from flatland_ma.sensors.hearing import MESSAGES


class ChannelBias:
    """The listening and signalling terms for a batched env's slots: ``num_slots`` slots,
    ``agents_per_world`` to a world (a slot's own speaker row is its agent's), ``tokens``
    words of ``vocabulary`` each, and the policy's heads ``sizes`` (moves first, then one
    per token)."""

    def __init__(
        self,
        listening: float,
        signalling: float,
        num_slots: int,
        agents_per_world: int,
        tokens: int,
        vocabulary: int,
        sizes: tuple[int, ...],
    ):
        if len(sizes) <= tokens:
            raise ValueError(f"heads {sizes} hold no moves beside {tokens} word heads")
        self.listening, self.signalling = listening, signalling
        self.num_slots, self.agents_per_world = num_slots, agents_per_world
        self.tokens, self.vocabulary = tokens, vocabulary
        self.moves = sum(sizes[: len(sizes) - tokens])
        """The width of the move heads' logits (they come first)."""
        self.sizes = sizes

    def speakers(self, index: torch.Tensor) -> torch.Tensor:
        """Which agent of its world each row is, from its entry in the rollout (``index``:
        step x slots + slot): its own row of the heard messages."""
        return (index % self.num_slots) % self.agents_per_world

    def changed(self, messages: torch.Tensor, own: torch.Tensor) -> torch.Tensor:
        """``messages`` (rows, speakers, 1 + tokens x vocabulary) with every speaker's
        words but the row's own (``own``: each row's agent, ``speakers``) moved on by one
        word."""
        rows, speakers, _ = messages.shape
        words = messages[..., 1:].reshape(rows, speakers, self.tokens, self.vocabulary)
        moved = words.roll(1, dims=-1)
        mine = torch.arange(speakers, device=messages.device)[None, :] == own[:, None]
        words = torch.where(mine[:, :, None, None], words, moved)
        return torch.cat([messages[..., :1], words.reshape(rows, speakers, -1)], dim=-1)

    def act(self, agent, observation: dict, action: torch.Tensor, state, index: torch.Tensor):
        """``agent.act(observation, action, state)``'s result, and the terms' loss and
        values (``losses/listening``, ``losses/signalling``), from one reading of the
        encodings."""
        parts = agent.encodings(observation)
        h = agent.join(parts)
        decided = agent.decide(h, action, state)
        logits = agent.actor(h)
        speakers = self.speakers(index)
        loss, values = h.new_zeros(()), {}
        if self.listening:
            changed = self.changed(observation[MESSAGES], speakers)
            other = agent.actor(agent.join({**parts, MESSAGES: agent.inputs[MESSAGES](changed)}))
            values["losses/listening"] = term = self.listened(logits, other)
            loss = loss - self.listening * term
        if self.signalling:
            values["losses/signalling"] = term = self.told(logits[:, self.moves :], speakers)
            loss = loss - self.signalling * term
        return decided, loss, {key: value.detach() for key, value in values.items()}

    def listened(self, logits: torch.Tensor, other: torch.Tensor) -> torch.Tensor:
        """The move heads' total variation between two readings' logits, summed over the
        heads, averaged over the rows."""
        heads = self.sizes[: len(self.sizes) - self.tokens]
        pairs = zip(
            logits[:, : self.moves].split(heads, -1), other[:, : self.moves].split(heads, -1)
        )
        tv = (0.5 * (p.softmax(-1) - q.softmax(-1)).abs().sum(-1).mean() for p, q in pairs)
        return sum(tv, logits.new_zeros(()))

    def told(self, words: torch.Tensor, speakers: torch.Tensor) -> torch.Tensor:
        """Per agent of a world (``speakers``: each row's) and word head, the entropy of
        its rows' mean distribution less their mean entropy, summed over the heads and
        averaged over the agents: one agent's words must vary with its situations, not
        merely differ from another's."""
        terms = []
        for who in speakers.unique():
            own = words[speakers == who]
            term = own.new_zeros(())
            for head in own.split(self.vocabulary, dim=-1):
                log_p = head.log_softmax(-1)
                p = log_p.exp()
                mean = p.mean(0)
                term = term - (mean * mean.clamp_min(1e-8).log()).sum() + (p * log_p).sum(-1).mean()
            terms.append(term)
        return torch.stack(terms).mean()


def channel_bias(args, env, agent) -> ChannelBias | None:
    """The run's ``ChannelBias`` (None without ``--listening`` and ``--signalling``);
    ``ValueError`` where there is no channel to hear or the policy has memory."""
    if not (args.listening or args.signalling):
        return None
    channel = env.spec.channel
    if args.no_channel or channel is None:
        raise ValueError(
            "--listening and --signalling bias the use of the channel: "
            f"{args.scenario} has none{' (--no-channel)' if args.no_channel else ''}"
        )
    if agent.remembers:
        raise ValueError(
            "--listening and --signalling train feed-forward policies (no --memory, --frames)"
        )
    return ChannelBias(
        args.listening,
        args.signalling,
        env.num_slots,
        env.agents_per_world,
        channel.tokens,
        channel.vocabulary,
        tuple(agent.sizes),
    )
