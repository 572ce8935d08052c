"""The recipes of docs/integrations.md as code: each block tagged
``<!-- recipe: NAME | runs on: TYPES -->``, run on each scenario type it lists with its
``STEPS`` made small (``tests/integrations/test_integrations.py`` and ``tests/clients/``)."""

from __future__ import annotations

import logging
import re
import sys
from pathlib import Path

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "integrations.md"
SCENARIO_LINE = 'SCENARIO, OPTIONS = "fruits_poisons_multi", {}'
"""The line every multi-scenario recipe starts from; the tests put each type's row in it."""

SMALL = {"sb3": 256, "sb3-batched": 256, "torchrl": 20, "torchrl-batched": 20, "skrl": 40,
         "skrl-batched": 40, "tianshou": 100, "agilerl": 128, "benchmarl": 200, "rllib": 200,
         "cleanrl": 520, "batched": 20}  # fmt: skip
"""Each recipe's ``STEPS`` in the tests."""

NEEDS = {"sb3": "stable_baselines3", "sb3-batched": "stable_baselines3", "torchrl": "torchrl",
         "torchrl-batched": "torchrl", "skrl": "skrl", "skrl-batched": "skrl",
         "tianshou": "tianshou", "agilerl": "agilerl", "benchmarl": "benchmarl", "rllib": "ray",
         "cleanrl": "gymnasium", "batched": "numpy"}  # fmt: skip
"""The module each recipe imports its client from."""

CLIENT_OF = {"sb3": "Stable-Baselines3", "sb3-batched": "Stable-Baselines3",
             "torchrl": "TorchRL", "torchrl-batched": "TorchRL", "skrl": "skrl",
             "skrl-batched": "skrl", "tianshou": "Tianshou", "agilerl": "AgileRL",
             "benchmarl": "BenchMARL", "rllib": "Ray RLlib",
             "cleanrl": "CleanRL-style", "batched": "CleanRL-style"}  # fmt: skip
"""The glue table's row of each recipe."""

VARIANTS = {"skrl-ippo": ("skrl", "mappo.MAPPO, mappo.MAPPO_CFG", "ippo.IPPO, ippo.IPPO_CFG")}
"""Recipes run a second time with one documented change: (recipe, old, new)."""


def guide_text() -> str:
    return GUIDE.read_text()


def recipes() -> dict[str, tuple[str, list[str]]]:
    """Every recipe of the guide: name -> (code, the scenario types it runs on)."""
    found = re.findall(
        r"<!-- recipe: ([\w-]+) \| runs on: ([\w ]+) -->\n```python\n(.*?)```", guide_text(), re.S
    )
    return {name: (code, types.split()) for name, types, code in found}


def scenarios() -> dict[str, tuple[str, dict]]:
    """The guide's scenario types: type -> (scenario, options)."""
    (code,) = re.findall(r"<!-- scenarios -->\n```python\n(.*?)```", guide_text(), re.S)
    namespace: dict = {}
    exec(compile(code, f"{GUIDE.name}:scenarios", "exec"), namespace)
    return namespace["SCENARIOS"]


def cases(names) -> list[tuple[str, str]]:
    """(recipe or variant, scenario type) for every type each named recipe lists."""
    every = recipes()
    found = []
    for name in names:
        base = VARIANTS[name][0] if name in VARIANTS else name
        found += [(name, kind) for kind in every[base][1]]
    return found


def runnable(name: str, kind: str) -> str:
    """Recipe ``name`` (or a variant) on scenario type ``kind``, its STEPS made small."""
    base, old, new = VARIANTS.get(name, (name, "", ""))
    code, kinds = recipes()[base]
    assert kind in kinds, f"the {base} recipe does not list {kind}"
    if old:
        assert code.count(old) == 1, f"{name}: the line to change is not in the recipe"
        code = code.replace(old, new)
    code, n = re.subn(r"^STEPS = [\d_]+$", f"STEPS = {SMALL[base]}", code, flags=re.M)
    assert n == 1, "each recipe sets STEPS once"
    if SCENARIO_LINE in code:
        scenario, options = scenarios()[kind]
        code = code.replace(SCENARIO_LINE, f"SCENARIO, OPTIONS = {scenario!r}, {options!r}")
    else:
        assert kinds == ["box"], f"{base} lists other types but has no scenario line"
    return code


def run(name: str, kind: str) -> dict:
    """Runs recipe ``name`` on scenario type ``kind``; returns its names."""
    namespace = {"__name__": f"recipe_{name}_{kind}"}
    exec(compile(runnable(name, kind), f"{GUIDE.name}:{name}:{kind}", "exec"), namespace)
    # skrl logs again when the process exits (it closes its envs then), through a handler
    # made on the stderr of its import: under pytest, a captured stream closed by then.
    for handler in logging.getLogger("skrl").handlers:
        if isinstance(handler, logging.StreamHandler):
            handler.setStream(sys.__stderr__)
    return namespace


def glue_table() -> dict[str, dict[str, str]]:
    """The guide's glue table: client -> scenario type -> cell."""
    lines = [ln for ln in guide_text().splitlines() if ln.startswith("| ")]
    header = [c.strip() for c in lines[0].strip("|").split("|")]
    rows = {}
    for line in lines[1:]:
        cells = [c.strip() for c in line.strip("|").split("|")]
        rows[cells[0]] = dict(zip(header[1:], cells[1:], strict=True))
    return rows


COLUMNS = {"Box camera": "box", "Dict senses": "dict", "different bodies": "bodies",
           "channel": "channel", "batched": "batched",
           "agents that finish early": "early_exit"}  # fmt: skip
"""The glue table's columns: the scenario type each names (``batched``: a batched recipe)."""


def covered(client: str, column: str) -> bool:
    """Whether some recipe of ``client`` runs on the glue table's ``column``."""
    kind = COLUMNS[column]
    for name, (_, kinds) in recipes().items():
        if CLIENT_OF[name] != client:
            continue
        if kind == "batched" and "batched" in name:
            return True
        if kind != "batched" and kind in kinds:
            return True
    return False
