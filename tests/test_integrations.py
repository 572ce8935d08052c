"""Every recipe of docs/integrations.md runs as written, with its STEPS made small."""

import re
from pathlib import Path

import pytest

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "integrations.md"
SMALL = {"sb3": 256, "sb3-multi": 256, "torchrl": 20, "skrl": 10, "tianshou": 2,
         "cleanrl": 520, "batched": 20}  # fmt: skip
NEEDS = {"sb3": "stable_baselines3", "sb3-multi": "stable_baselines3", "torchrl": "torchrl",
         "skrl": "skrl", "tianshou": "tianshou", "cleanrl": "gymnasium",
         "batched": "numpy"}  # fmt: skip


def recipes() -> dict[str, str]:
    text = GUIDE.read_text()
    found = re.findall(r"<!-- recipe: ([\w-]+) -->\n```python\n(.*?)```", text, re.S)
    return dict(found)


def test_the_guide_has_every_recipe():
    assert set(recipes()) == set(SMALL)


@pytest.mark.parametrize("name", sorted(SMALL))
def test_recipe_runs(name):
    pytest.importorskip(
        NEEDS[name], reason=f"the {name} recipe needs {NEEDS[name]} (extra: clients)"
    )
    code = recipes()[name]
    small, n = re.subn(r"^STEPS = [\d_]+$", f"STEPS = {SMALL[name]}", code, flags=re.M)
    assert n == 1, "each recipe sets STEPS once"
    exec(compile(small, f"{GUIDE.name}:{name}", "exec"), {"__name__": f"recipe_{name}"})


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
