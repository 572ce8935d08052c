"""The scores line of a shipped scenario's header comment: random play and the scenario's
reference solver, mean ± std of the mean return per agent over seeded episodes.

    python -m flatland_ma.policies.scores_header NAME [--episodes 20]

``make scenario-page NAME=...`` runs it after drawing the scenario's picture; paste what
it prints into the file's header (the library tests look for "Scores", "random" and the
solver's name there).
"""

from __future__ import annotations

import argparse

from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.policies import named
from flatland_ma.policies.named import make_policy
from flatland_ma.policies.rollout import evaluate


def solver_names(env: FlatlandParallelEnv) -> dict[str, str]:
    """The policy the scenario's reference solver gives each agent, by name
    (``ValueError`` if it names none)."""
    if env.spec.reference is None:
        raise ValueError("the scenario has no 'reference' solver")
    return named.solver_names(env)


def scores_line(name: str, episodes: int = 20) -> str:
    """The header's line: ``Scores, mean ± std over N episodes (seeds 0-N-1): random
    X ± Y; SOLVER A ± B.``"""
    env = FlatlandParallelEnv(name)
    agents = env.possible_agents
    solver = solver_names(env)
    played = {
        "random": evaluate(env, lambda a: make_policy("random", env, a, agents.index(a)), episodes),
        env.spec.reference.solver: evaluate(  # type: ignore[union-attr]
            env, lambda a: make_policy(solver[a], env, a, agents.index(a)), episodes
        ),
    }
    parts = [f"{who} {s.mean:.3g} ± {s.std:.2g}" for who, s in played.items()]
    return (
        f"# Scores, mean ± std over {episodes} episodes (seeds 0-{episodes - 1}): "
        + "; ".join(parts)
        + "."
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="The scores line of a scenario's header.")
    parser.add_argument("name", help="a shipped scenario's name, or a scenario file")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per policy")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error("--episodes must be at least 1")
    print(scores_line(args.name, args.episodes))


if __name__ == "__main__":
    main()
