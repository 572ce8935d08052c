"""Tasks are versioned: each scenario file carries a ``version``, the Gymnasium ids name it,
benchmark results record it, and results of different versions never mix."""

import json

import gymnasium
import pytest

import flatland_ma
from baselines.benchmark.records import (
    ConfigurationMismatch,
    VersionMismatch,
    check_current,
    read_results,
    task_versions,
)
from baselines.benchmark.runs import run
from baselines.benchmark.settings import SETTINGS, load_config
from flatland_ma.envs import registration
from flatland_ma.envs.registration import gym_id, register_gym_ids
from flatland_ma.scenario.errors import ScenarioError


def test_a_scenario_is_at_version_0_unless_its_file_says_otherwise():
    import yaml

    from flatland_ma.scenario.shipped import scenario_files

    for path in scenario_files():
        said = yaml.safe_load(path.read_text(encoding="utf-8")).get("version", 0)
        assert flatland_ma.load_scenario(path.stem).version == said, path.stem
    assert flatland_ma.load_scenario("signal_rooms").version == 2  # bumped 2026-12-01, 2026-12-02
    assert flatland_ma.load_scenario("signal_maps").version == 1  # bumped 2026-12-02
    assert flatland_ma.load_scenario("fruits_poisons", version=3).version == 3
    for wrong in (-1, 1000, "1", 1.0, True):
        with pytest.raises(ScenarioError, match="version"):
            flatland_ma.load_scenario("fruits_poisons", version=wrong)


def test_gymnasium_ids_name_the_version_and_only_the_current_one_is_registered(monkeypatch):
    assert gym_id("fruits_poisons") == "flatland_ma/FruitsPoisons-v0"
    assert gym_id("fruits_poisons", 2) == "flatland_ma/FruitsPoisons-v2"
    assert "flatland_ma/FruitsPoisons-v0" in flatland_ma.GYM_IDS
    names = flatland_ma.list_scenarios()
    singles = [s for s in names if flatland_ma.load_scenario(s).n_agents == 1]
    assert flatland_ma.GYM_IDS == [gym_id(s) for s in singles]
    # A scenario whose file said version 2: its id is -v2, and v0 is not there.
    entry = {"version": 2, "n_agents": 1, "max_steps": 500}
    monkeypatch.setattr(registration, "_entries", lambda: {"key_door": entry})
    try:
        assert register_gym_ids() == ["flatland_ma/KeyDoor-v2"]
        assert gymnasium.spec("flatland_ma/KeyDoor-v2").kwargs["scenario"] == "key_door"
        assert gym_id("key_door") == "flatland_ma/KeyDoor-v2"
    finally:
        gymnasium.registry.pop("flatland_ma/KeyDoor-v2", None)
    with pytest.raises(gymnasium.error.VersionNotFound, match="v3"):
        gymnasium.make("flatland_ma/KeyDoor-v3")


def test_results_record_the_version_of_every_scenario_a_task_plays():
    assert task_versions("fruits_poisons", "scenario") == {"fruits_poisons": 0}
    stream = task_versions("cross_domain", "stream")
    assert stream == dict.fromkeys(
        ["fruits_poisons", "obstacle_forest", "seek_avoid_rooms", "textured_fruits"], 0
    )


def _write(root, task, method, seed, versions=None):
    path = root / task / method / f"seed_{seed}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {"task": task, "method": method, "seed": seed, "score": 1.0}
    if versions is not None:
        record["task_versions"] = versions
    path.write_text(json.dumps(record))
    return path


def test_the_benchmark_refuses_to_run_beside_results_of_another_version(tmp_path):
    fruits = [("fruits_poisons", "scenario")]
    _write(tmp_path, "fruits_poisons", "random", 0)  # from before versions: version 0
    _write(tmp_path, "fruits_poisons", "scripted", 0, {"fruits_poisons": 0})
    config = load_config(SETTINGS)
    assert run(config, fruits, [], out=tmp_path) == []
    stale = _write(tmp_path, "fruits_poisons", "ppo", 3, {"fruits_poisons": 1})
    with pytest.raises(VersionMismatch) as refused:
        run(config, fruits, ["random"], out=tmp_path)
    message = str(refused.value)
    assert str(stale) in message and "fruits_poisons v1" in message
    assert "fruits_poisons v0" in message and "never mix" in message


def test_the_table_refuses_a_task_whose_results_are_of_different_versions(tmp_path):
    old = _write(tmp_path, "key_door", "random", 0)
    new = _write(tmp_path, "key_door", "random", 1, {"key_door": 2})
    with pytest.raises(VersionMismatch) as refused:
        read_results(tmp_path)
    assert str(old) in str(refused.value) and str(new) in str(refused.value)
    assert "key_door v2" in str(refused.value)
    new.unlink()
    check_current("key_door", "scenario", read_results(tmp_path)["key_door"])
    made_on_2 = {"random": [{"task_versions": {"key_door": 2}}]}
    with pytest.raises(VersionMismatch, match="made on key_door v2, the task is now version 0"):
        check_current("key_door", "scenario", made_on_2)


def test_a_result_written_names_its_versions(tmp_path):
    shipped = load_config(SETTINGS)
    config = shipped.model_copy(update={"seeds": 1, "episodes": 1})
    [path] = run(config, [("push_box", "scenario")], ["random"], tmp_path, tmp_path / "runs")
    record = json.loads(path.read_text())
    assert record["task_versions"] == {"push_box": 0} and record["task"] == "push_box"
    assert run(config, [("push_box", "scenario")], ["random"], tmp_path, tmp_path / "runs") == []


def test_the_benchmark_refuses_to_resume_beside_results_of_another_configuration(tmp_path):
    config = load_config(SETTINGS)
    standard = config.tier("standard")
    named = standard.task("key_door").name
    path = tmp_path / "key_door" / "ppo" / "standard" / "seed_1.json"
    path.parent.mkdir(parents=True)
    record = {"task": "key_door", "method": "ppo", "seed": 1, "score": 1.0, "tier": "standard"}
    path.write_text(json.dumps({**record, "configuration": named}))
    # The same configuration passes (and, out of time at once, nothing is trained).
    tasks = [("key_door", "scenario")]
    assert run(config, tasks, ["ppo"], tmp_path, tier="standard", hours=1e-12) == []
    path.write_text(json.dumps({**record, "configuration": "a GRU, 64 worlds"}))
    with pytest.raises(ConfigurationMismatch) as refused:
        run(config, tasks, ["ppo"], tmp_path, tier="standard", hours=1e-12)
    message = str(refused.value)
    assert str(path) in message and "'a GRU, 64 worlds'" in message and repr(named) in message
