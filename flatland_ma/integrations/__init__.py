"""Adapters and wrappers for clients that lack a door of their own.

Each module imports its client (if it needs one) only when used; nothing in the layers
below imports this package.

- ``discrete``: ``DiscreteActions``, one ``Discrete`` action per agent for scenarios with
  a channel (moves x words), for clients that take only ``Discrete`` or ``Box`` actions.
- ``inert``: ``InertFinished``, finished agents kept present and inert (zeros, reward 0,
  actions ignored, ``infos[agent]["active"]`` False) until their world's episode ends for
  all, for clients that expect every agent in every step (AgileRL).
- ``sb3``: ``SB3VecEnv``, Stable-Baselines3's ``VecEnv`` over the batched env, every agent
  of every world a slot, with SB3's resets and no made-up transitions.
- ``benchmarl``: ``flatland_task(scenario, **overrides)``, a BenchMARL task of any
  scenario (flat observations, one ``Discrete`` action, the global state, masks).
"""
