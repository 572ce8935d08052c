"""Baselines: the Flatland paper's experiment on ``fruits_poisons``, and learners for
the multi-agent and lifelong tasks.

One readable file per algorithm, after CleanRL: ``dqn.py`` (keras-rl's DQN),
``a3c.py`` (universe-starter-agent's A3C, with a synchronous A2C mode), ``dfp.py``
(Direct Future Prediction), ``ppo.py`` (shared-parameter PPO for several agents, on the
batched env), ``lifelong.py`` (PPO through a task stream: fine-tuning, cloning from
replay, and the single-task reference) and ``rllib_ppo.py`` (Ray RLlib). ``networks.py``
encodes any observation by its entries' shapes; ``common.py`` holds the pieces the
paper's three share; ``run.py`` runs many seeds. They run on any scenario: the log's
counters are the scenario's own (``common.info_counters``).

The reports live apart, in ``benchmark/``, and the learners never import them: the
benchmark (``python -m baselines.benchmark``) and its page, the levels, the paper's figure
and results table (``benchmark/plot.py``) and the learner's speed against its parts
(``benchmark/learner_speed.py``).

    python -m baselines.dqn --seed 0 --total-timesteps 250000
    python -m baselines.run dqn --seeds 30 --workers 2 --steps 250000 --out runs
    python -m baselines.benchmark.plot runs/dqn/fruits_poisons runs/a3c/fruits_poisons
"""

import os

# OpenMP's idle threads must sleep, not spin: the batched env's ray kernel runs on numba's
# OpenMP threads, and once torch has loaded libgomp with its default (spinning) policy they
# keep both cores busy after every step, which made each of the learner's convolutions
# 50 times slower. flatland_ma asks for this too, but only when its kernel is imported,
# which is after torch here; libgomp reads the policy once, when it is loaded.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

ALGORITHMS = ("dqn", "a3c", "dfp", "ppo")
