"""docs/integrations.md: every recipe of the main environment runs as written (the Box
row, its STEPS made small), the glue table covers every client and scenario type, and a
0 in it stands only where a recipe is run on that type (all types: make test-clients)."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "clients"))
from recipes import (  # noqa: E402
    CLIENT_OF,
    COLUMNS,
    GUIDE,
    NEEDS,
    covered,
    glue_table,
    recipes,
    run,
    scenarios,
)

MAIN_VENV = ["sb3", "sb3-batched", "torchrl", "torchrl-batched", "skrl", "skrl-batched",
             "tianshou", "cleanrl", "batched"]  # fmt: skip
"""Recipes whose clients are in the ``clients`` extra; AgileRL and BenchMARL run only in
their own environments (make test-clients)."""


def test_the_guide_has_every_recipe_and_each_lists_known_types():
    assert set(recipes()) == set(NEEDS)
    for name, (_, kinds) in recipes().items():
        assert kinds and set(kinds) <= set(scenarios()), name


@pytest.mark.parametrize("name", MAIN_VENV)
def test_recipe_runs_as_written(name):
    pytest.importorskip(NEEDS[name], reason=f"the {name} recipe needs {NEEDS[name]} (clients)")
    run(name, "box")


def test_the_glue_table_has_every_client_and_type_and_zero_only_where_tested():
    table = glue_table()
    clients = set(CLIENT_OF.values()) | {"Ray RLlib"}
    assert set(table) == clients
    for client, row in table.items():
        assert set(row) == set(COLUMNS), client
        for column, cell in row.items():
            if cell[:1].isdigit():  # lines of glue: a recipe runs it
                assert covered(client, column), f"{client} / {column}: {cell} but no recipe runs it"
            elif covered(client, column):
                pytest.fail(f"{client} / {column} is run by a recipe, yet the table says {cell!r}")


def test_the_rllib_lines_are_those_of_the_tested_script():
    """The RLlib recipe runs in its own environment (make test-rllib) as
    baselines/rllib_ppo.py: the guide shows that script's own lines."""
    script = (GUIDE.parent.parent / "baselines" / "rllib_ppo.py").read_text()
    guide = GUIDE.read_text()
    for line in (
        "ParallelPettingZooEnv(FlattenObservations(flatland_ma.parallel_env(config[",
        '.multi_agent(policies={"shared"}, policy_mapping_fn=',
        'register_env("flatland_ma_parallel", make_env)',
    ):
        assert line in guide and line in script.replace("ENV_NAME", '"flatland_ma_parallel"'), line
