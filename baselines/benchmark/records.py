"""The benchmark's per-seed JSON files: where each goes, writing and reading them, and the
versions of the scenarios a result was made on (results of different versions of a task
never mix: ``VersionMismatch``)."""

from __future__ import annotations

import json
from pathlib import Path

from baselines.benchmark.settings import LEARNED, ROOT

OUT = ROOT / "results" / "benchmark"
RUNS = ROOT / "runs" / "benchmark"


def result_path(out: Path, name: str, method: str, seed: int, tier: str = "smoke") -> Path:
    """A seed's result: ``<out>/<task>/<method>/seed_<k>.json``, or for a learned method
    in a tier other than smoke ``<out>/<task>/<method>/<tier>/seed_<k>.json``."""
    if method in LEARNED and tier != "smoke":
        return out / name / method / tier / f"seed_{seed}.json"
    return out / name / method / f"seed_{seed}.json"


def tier_runs(runs: Path, tier: str) -> Path:
    """Where a tier's checkpoints and logs go: ``runs`` for smoke, ``runs/<tier>`` else."""
    return runs if tier == "smoke" else runs / tier


def write_record(path: Path, record: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_suffix(".part")
    part.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    part.replace(path)


class VersionMismatch(ValueError):
    """Results of a task's other version where this one's would go, or beside them."""


def task_versions(name: str, kind: str) -> dict[str, int]:
    """The version of every scenario a task plays, by scenario: the scenario itself, or
    each scenario of a stream's tasks (with the stream's overrides, as it plays them)."""
    if kind == "scenario":
        from flatland_ma.scenario.loader import load_scenario

        return {name: load_scenario(name).version}
    from flatland_ma.lifelong import load_stream

    stream = load_stream(name)
    spec = stream.spec
    named = [t.scenario for t in spec.tasks] if spec.tasks else [spec.never_ending.scenario]
    return {str(n): scenario.version for n, scenario in zip(named, stream.scenarios)}


def recorded_versions(record: dict, today: dict[str, int]) -> dict[str, int]:
    """The scenario versions a result was made on (a record from before tasks carried
    versions: version 0 of each scenario the task plays today)."""
    return record.get("task_versions", dict.fromkeys(today, 0))


def check_versions(path: Path, today: dict[str, int]) -> None:
    """``VersionMismatch`` if the result at ``path`` was made on other versions."""
    made = recorded_versions(json.loads(path.read_text(encoding="utf-8")), today)
    if made != today:
        raise VersionMismatch(
            f"{path} was made on {versions_text(made)}, the task is now {versions_text(today)}: "
            "results of different versions never mix; move the task's old results away "
            "and run it again"
        )


class ConfigurationMismatch(ValueError):
    """A learned method's result of a tier, trained in another configuration than the one
    the settings now name for its task."""


def check_configuration(path: Path, name: str) -> None:
    """``ConfigurationMismatch`` if the result at ``path`` names a configuration other
    than ``name`` (a record that names none passes)."""
    made = json.loads(path.read_text(encoding="utf-8")).get("configuration")
    if made is not None and made != name:
        raise ConfigurationMismatch(
            f"{path} was trained as {made!r}, the settings now name {name!r}: results of "
            "different configurations never mix; move the task's old results away and run "
            "it again"
        )


def versions_text(versions: dict[str, int]) -> str:
    """``{"fruits_poisons": 1}`` -> ``fruits_poisons v1``."""
    return ", ".join(f"{name} v{version}" for name, version in sorted(versions.items()))


def version_key(versions: dict | None) -> str:
    """One text per set of versions; a record from before tasks carried versions (None)
    counts as version 0 of every scenario."""
    versions = {k: v for k, v in (versions or {}).items() if v != 0}
    return versions_text(versions) if versions else "version 0"


def read_results(root: Path, tier: str = "smoke") -> dict[str, dict[str, list[dict]]]:
    """``{task: {method: [record of each seed, by seed]}}`` from ``root``'s JSON files: a
    learned method's records of ``tier`` (a record without a tier is smoke's), every
    other method's records; ``VersionMismatch`` if one task's files were made on
    different versions."""
    out: dict[str, dict[str, list[dict]]] = {}
    made: dict[str, dict[str, Path]] = {}
    paths = sorted(root.glob("*/*/seed_*.json")) + sorted(root.glob("*/*/*/seed_*.json"))
    for path in paths:
        record = json.loads(path.read_text(encoding="utf-8"))
        if record["method"] in LEARNED and record.get("tier", "smoke") != tier:
            continue
        out.setdefault(record["task"], {}).setdefault(record["method"], []).append(record)
        made.setdefault(record["task"], {}).setdefault(
            version_key(record.get("task_versions")), path
        )
    for task, found in made.items():
        if len(found) > 1:
            (one, first), (other, second) = list(found.items())[:2]
            raise VersionMismatch(
                f"results of {task} were made on different versions: {first} on {one}, "
                f"{second} on {other}; results of different versions never mix"
            )
    for methods in out.values():
        for records in methods.values():
            records.sort(key=lambda r: r["seed"])
    return out


def check_current(name: str, kind: str, methods: dict[str, list[dict]]) -> None:
    """``VersionMismatch`` if a task's results were made on other versions than today's."""
    records = [r for rs in methods.values() for r in rs]
    today = version_key(task_versions(name, kind))
    if records and version_key(records[0].get("task_versions")) != today:
        made = version_key(records[0].get("task_versions"))
        raise VersionMismatch(
            f"the results of {name} were made on {made}, the task is now {today}: run "
            "baselines.benchmark for it again (after moving its old results away)"
        )
