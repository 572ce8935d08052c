"""Every recipe of docs/integrations.md on every scenario type it lists (make test-clients).

Which recipes run is set by ``FLATLAND_CLIENTS`` (recipe names, space separated), since each
client's environment holds only its own: the main ``.venv`` runs the ``clients`` extra's,
``.venv-clients-agilerl`` AgileRL's, ``.venv-clients-benchmarl`` BenchMARL's. Unset, every
recipe runs (and those whose client is missing fail)."""

import os
import warnings

import pytest
from recipes import NEEDS, VARIANTS, cases, run

NAMES = os.environ.get("FLATLAND_CLIENTS", " ".join([*NEEDS, *VARIANTS])).split()


@pytest.mark.parametrize(("name", "kind"), cases(NAMES))
def test_the_recipe_trains_on_the_scenario_type_unchanged(name, kind, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # logs and checkpoints some clients write by default
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the clients' own deprecation and shape notes
        names = run(name, kind)
    assert names["STEPS"] >= 1
