"""Named settings of ``baselines.ppo`` for a task (``--preset NAME``), each with the runs
that chose it in docs/results.md. A preset sets only the options a run leaves at their
defaults, so ``--preset fruits_poisons --seed 3 --ent-coef 0.05`` keeps the 0.05."""

from __future__ import annotations

import dataclasses

PRESETS: dict[str, dict] = {
    # The paper's task, one agent: CleanRL's settings pass 300 (mean of 50 episodes) and
    # then sink to 278-302, which we take for a reactive policy sharpening into loops. A
    # larger entropy bonus keeps it stochastic (the last 50 episodes: 294-305 over five
    # seeds), and the depth channel beside the colours lifts the policy's mean above the
    # line (303-310 over seeds 0-2 with --overlap; docs/results.md).
    "fruits_poisons": {
        "scenario": "fruits_poisons",
        "num_envs": 16,
        "total_timesteps": 2_600_000,
        "ent_coef": 0.03,
        "use_depth": True,
        "checkpoint_every": 0,
    },
}


def with_preset(args):
    """``args`` with its preset's settings in every field still at its default."""
    if not args.preset:
        return args
    if args.preset not in PRESETS:
        raise ValueError(f"no preset {args.preset!r}; there are: {', '.join(sorted(PRESETS))}")
    defaults = type(args)()
    changes = {
        name: value
        for name, value in PRESETS[args.preset].items()
        if getattr(args, name) == getattr(defaults, name)
    }
    return dataclasses.replace(args, **changes)
