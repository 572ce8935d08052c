"""What the README tells a newcomer: the Layout section names every package and top-level
module of flatland_ma, and there is a ``pip install`` line for those who skip make."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def layout() -> str:
    """The Layout section's tree (its first code block)."""
    section = README.split("\n## Layout\n", 1)[1].split("\n## ", 1)[0]
    return section.split("```", 2)[1]


def test_the_layout_names_every_package_and_module_of_flatland_ma():
    package = ROOT / "flatland_ma"
    names = sorted(
        [f"{p.name}/" for p in package.iterdir() if (p / "__init__.py").is_file()]
        + [p.name for p in package.glob("*.py") if p.name != "__init__.py"]
    )
    assert "envs/" in names and "bench/" in names and "cli/" in names
    # An entry of flatland_ma/ starts a line indented by two spaces; a file named within
    # another entry's description (envs/ has a vector.py too) is not one.
    entries = {m.group(1) for m in re.finditer(r"^  (\S+)", layout(), re.MULTILINE)}
    missing = [name for name in names if name not in entries]
    assert missing == [], f"README.md's Layout does not name {missing}"


def test_the_readme_says_how_to_install_with_pip():
    lines = [line.strip() for line in README.splitlines()]
    assert any(line.startswith('pip install -e ".[') for line in lines)
    assert any(line.startswith('pip install ".[') for line in lines)


def test_the_license_and_the_citation_agree_with_pyproject_and_the_paper():
    import yaml

    license_text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert license_text.startswith("MIT License\n")
    assert "Copyright (c) 2026 flatland_ma contributors" in license_text
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")  # tomllib: 3.11+
    project = dict(re.findall(r'^(license|version) = "(.*)"$', pyproject, re.MULTILINE))
    assert project["license"] == "MIT"
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert citation["license"] == "MIT" and citation["version"] == project["version"]
    paper = citation["preferred-citation"]
    title = "Flatland: a Lightweight First-Person 2-D Environment for Reinforcement Learning"
    assert paper["title"] == title
    assert [a["family-names"] for a in paper["authors"]] == [
        "Caselles-Dupré", "Annabi", "Hagen", "Garcia-Ortiz", "Filliat"
    ]  # fmt: skip
    bibtex = README.split("```bibtex\n", 1)[1].split("```", 1)[0]
    assert f"title  = {{{title}}}" in bibtex and "Filliat, David" in bibtex


def test_the_install_lines_say_the_package_is_installed_from_a_clone():
    assert "not on PyPI" in README
    assert 'pip install "flatland-ma' not in README and "pip install flatland-ma" not in README
