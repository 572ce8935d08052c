"""The package as users install it: the wheel holds every file of ``scenarios/`` as the
package data ``flatland_ma/scenarios/``, and an install from it finds them there (through
``importlib.resources``, not the source tree)."""

import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import flatland_ma

ROOT = Path(__file__).resolve().parent.parent
SOURCES = ["pyproject.toml", "README.md", "flatland_ma", "scenarios"]
"""What a build reads: copied, so that building leaves no build/ folder in the tree."""


@pytest.fixture(scope="module")
def build(tmp_path_factory) -> tuple[Path, str]:
    """The wheel built from a copy of the sources, and what the build printed."""
    source, out = tmp_path_factory.mktemp("source"), tmp_path_factory.mktemp("wheel")
    for name in SOURCES:
        if (ROOT / name).is_dir():
            ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
            shutil.copytree(ROOT / name, source / name, ignore=ignore)
        else:
            shutil.copy2(ROOT / name, source / name)
    command = [sys.executable, "-m", "pip", "wheel", str(source), "--no-deps"]
    command += ["--no-build-isolation", "--wheel-dir", str(out)]
    quiet = {**os.environ, "PIP_DISABLE_PIP_VERSION_CHECK": "1"}
    run = subprocess.run(command, capture_output=True, text=True, env=quiet)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-4000:]
    (built,) = out.glob("flatland_ma-*.whl")
    return built, run.stdout + run.stderr


@pytest.fixture(scope="module")
def wheel(build) -> Path:
    return build[0]


@pytest.fixture(scope="module")
def wheel_log(build) -> str:
    return build[1]


def test_the_wheel_holds_every_scenario_file_as_package_data(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    shipped = sorted(p.name for p in (ROOT / "scenarios").iterdir() if p.is_file())
    assert "scenario.schema.json" in shipped and "maze_goal.yaml" in shipped
    missing = [name for name in shipped if f"flatland_ma/scenarios/{name}" not in names]
    assert missing == [], f"not in {wheel.name}: {missing}"
    assert not [name for name in names if name.startswith("scenarios/")]
    for folder, example in (("suites", "society.yaml"), ("streams", "never_ending.yaml")):
        files = sorted(p.name for p in (ROOT / "scenarios" / folder).iterdir() if p.is_file())
        assert example in files
        missing = [s for s in files if f"flatland_ma/scenarios/{folder}/{s}" not in names]
        assert missing == [], f"not in {wheel.name}: {folder}/{missing}"


def test_the_wheel_holds_the_studios_built_pages(wheel):
    """The studio needs no npm once installed: its built pages are package data."""
    names = set(zipfile.ZipFile(wheel).namelist())
    static = ROOT / "flatland_ma" / "studio" / "static"
    built = sorted(str(p.relative_to(ROOT)) for p in static.rglob("*") if p.is_file())
    assert "flatland_ma/studio/static/index.html" in built
    assert any(name.endswith(".js") for name in built)
    missing = [name for name in built if name not in names]
    assert missing == [], f"not in {wheel.name}: {missing}"


def test_the_build_prints_no_warning_from_our_configuration(wheel_log):
    """setuptools prints a warning block (``SetuptoolsDeprecationWarning``,
    ``BuildBackendWarning``) for what it dislikes in pyproject.toml: a license table, a
    folder of package data that is no listed package. The build prints none."""
    assert re.findall(r"\w*Warning\b.*", wheel_log) == [], wheel_log[-4000:]


def test_the_wheel_holds_every_module_of_the_package(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    modules = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "flatland_ma").rglob("*.py"))
    assert "flatland_ma/play/keys.py" in modules
    missing = [name for name in modules if name not in names]
    assert missing == [], f"not in {wheel.name} (list its package in pyproject.toml): {missing}"


def test_an_install_from_the_wheel_lists_and_loads_the_scenarios(wheel, tmp_path):
    site = tmp_path / "site"
    command = [sys.executable, "-m", "pip", "install", "--no-deps", "--quiet"]
    subprocess.run(command + ["--target", str(site), str(wheel)], check=True, capture_output=True)
    code = (
        "import flatland_ma\n"
        "from flatland_ma.scenario.loader import schema_path\n"
        "print(flatland_ma.__file__)\n"
        "print(schema_path().is_file())\n"
        "print(' '.join(flatland_ma.list_scenarios()))\n"
        "print(flatland_ma.load_scenario('fruits_poisons_multi').n_agents)\n"
    )
    # The installed copy comes first on the path, before this checkout's editable install.
    env = {**os.environ, "PYTHONPATH": str(site)}
    run = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr
    module, schema, names, n_agents = run.stdout.splitlines()
    assert Path(module).is_relative_to(site)
    assert schema == "True" and n_agents == "4"
    assert names.split() == flatland_ma.list_scenarios()
