"""The benchmark: random play, open-loop play, each task's scripted reference solver and
shared-parameter PPO (in tiers of budget) on every shipped scenario and task stream, seed
by seed, one small JSON file per seed.

    python -m baselines.benchmark                        # the smoke tier: all not yet done
    python -m baselines.benchmark --tier standard        # 1M agent-steps x 5 seeds
    python -m baselines.benchmark --methods random scripted open_loop
    python -m baselines.benchmark --only fruits_poisons coop_carry --methods ppo

``make benchmark [TIER=standard]`` runs it (``__main__.py``: the command; ``runs.py``:
seed by seed), then ``python -m baselines.benchmark.table`` (``make benchmark-table``),
which writes docs/benchmark.md from the JSON files alone.

A task is a shipped scenario (``flatland_ma.list_scenarios()``) or a shipped stream
(``scenarios/streams/``). Each method plays it on the same held-out episodes:

- a scenario: ``episodes`` episodes reset with seeds ``eval_seed``, ``eval_seed + 1``, ...
  (apart from every training world); its score is the mean return per agent that the
  scenario's reference counts (every agent; with ``carrier_vs_random``, the first team's,
  the others playing at random);
- a stream of tasks: each task's world, episodes seeded as ``baselines.lifelong``'s
  evaluation blocks seed them, every agent played by the method; its score is the mean over
  the stream's tasks of the mean return per agent (the "average performance" at the end
  of a life). The never-ending stream is scored on its first ``never_ending_steps`` steps.

Methods (played by ``play.py``, PPO trained by ``train.py``): ``random`` (every agent
uniform at random, seeded by the seed), ``scripted`` (the reference solver
``flatland_ma.policies.scores_header.solver_names`` gives each agent, seeded by the seed),
``open_loop`` (actions by the time step alone: the best of a few random schedules on
training episodes, ``baselines.open_loop``) and ``ppo``: ``baselines.ppo`` on a scenario,
``baselines.lifelong --method finetune`` through a stream of tasks and
``baselines.never_ending`` through the never-ending one, for the task's budget of
agent-steps (``baselines/benchmark/settings.yaml``), then the final checkpoint is scored
(a stream of tasks: by its learner's last evaluation block); ``ppo_no_channel``, the
channel's ablation on every scenario with a channel: ``baselines.ppo`` in the task's
configuration of the tier with ``--no-channel``, scored without the channel too.

PPO runs in tiers (``--tier``; ``settings.yaml``, read by ``config.py``): ``smoke`` (100k
agent-steps x 3 seeds, regressions only), ``standard`` (1M x 5 seeds, every task in the best shipped
configuration for it, each named) and ``certificate`` (10M x 3 seeds, the tasks the
settings list). Random, scripted and open-loop play do not depend on a budget: their
results serve every tier.

Each result goes to ``<out>/<task>/<method>/seed_<k>.json`` (PPO and its ablation in a
tier other than smoke: ``<out>/<task>/<method>/<tier>/seed_<k>.json``): the score, each
episode's, the budget, agent-steps, the configuration's name and options, CPU and wall
seconds, a calibration (a fixed matrix product timed at the start of the run,
``machine.py``), the version of every scenario the task plays, package versions, commit
and the machine's load; PPO on a scenario also its learning curve (``curves.py``). A seed
whose file exists is skipped, so an interrupted run resumes; a seed's PPO training
interrupted on a scenario goes on from its newest checkpoint (every 100 updates:
``baselines.ppo --resume``), and its file then names the agent-steps where it resumed
and counts every process's seconds. Results of different
versions of a task never mix: a seed file of another version than the task's today stops
the run (``VersionMismatch``), and ``baselines.benchmark.table`` refuses a task whose
files disagree. A file written before tasks carried versions counts as version 0 of every
scenario it plays. Checkpoints and logs go to ``<runs>/<task>/`` (a tier other than smoke:
``<runs>/<tier>/<task>/``; not committed).

The package's other modules: ``records.py`` (the JSON files, their paths and versions);
``summary.py``, ``page.py``, ``tables.py``, ``figures.py`` and ``table.py`` (the page from
the files); ``levels.py`` (runs held to a level, ``python -m baselines.benchmark.levels``);
``plot.py`` (the paper's figure from ``baselines.run``'s seeds, ``python -m
baselines.benchmark.plot``) and ``learner_speed.py`` (``baselines.ppo`` against its parts,
``python -m baselines.benchmark.learner_speed``). The learners never import this package.
"""
