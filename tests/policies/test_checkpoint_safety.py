"""No checkpoint can run code, and every malformed one gets a located error.

Old-format checkpoints (``torch.save`` of a dict with a ``torch.export`` program) carry
payloads in each place that format lets a pickle in: the top-level pickle, and in the
program a weight marked as pickled, the sample inputs and an opaque constant. A first
test shows each payload is live (the old loader creates its marker); then every loader
(``CheckpointPolicy``, ``read_checkpoint``, ``make_policy``, the suite runner's
``trained_with`` check, ``record --policy``) refuses each file naming it and saying how
to convert, and no marker appears. Data-only files with hostile headers, descriptions
and tensors, and paths that are not regular files, are refused with the file and the
entry named."""

from __future__ import annotations

import json
import os
import pickle
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

import flatland_ma  # noqa: E402
from baselines.networks import Agent  # noqa: E402
from flatland_ma.cli import main  # noqa: E402
from flatland_ma.evaluation.runner import check_held_out  # noqa: E402
from flatland_ma.evaluation.suite import load_suite  # noqa: E402
from flatland_ma.policies import tensor_file  # noqa: E402
from flatland_ma.policies.checkpoint import (  # noqa: E402
    CheckpointPolicy,
    read_checkpoint,
    write_checkpoint,
)
from flatland_ma.policies.named import make_policy  # noqa: E402
from tests.checkpoint_helpers import (  # noqa: E402
    PLACES,
    Payload,
    exported,
    planted,
    rewrite_description,
    write_old_checkpoint,
)

ROOT = Path(__file__).resolve().parents[2]
ENV = flatland_ma.parallel_env("fruits_poisons")


@pytest.fixture(scope="module")
def program() -> bytes:
    observations, _ = ENV.reset(seed=0)
    agent = Agent(ENV.observation_space("agent_0"), ENV.action_space("agent_0"), hidden=8)
    return exported(agent, observations["agent_0"][None])


def _old_files(folder: Path, program: bytes) -> dict[str, tuple[Path, Path]]:
    """Each payload's old-format checkpoint and its marker (which must never appear)."""
    entries = {
        "scenario": "fruits_poisons",
        "observation_space": str(ENV.observation_space("agent_0")),
        "action_space": str(ENV.action_space("agent_0")),
        "action_sizes": [3],
        "trained_with": ["self"],
    }
    files = {}
    for place in PLACES:
        marker = folder / f"ran_{place}"
        path = folder / f"{place}.pt"
        files[place] = (
            write_old_checkpoint(path, planted(program, place, marker), **entries),
            marker,
        )
    marker = folder / "ran_top_level"
    top = folder / "top_level.pt"
    torch.save({"format": "flatland_ma.policy", "version": 1, **entries, "x": Payload(marker)}, top)
    files["top_level"] = (top, marker)
    marker = folder / "ran_bare_pickle"
    bare = folder / "bare_pickle.pt"
    bare.write_bytes(pickle.dumps({"format": "flatland_ma.policy", "x": Payload(marker)}))
    files["bare_pickle"] = (bare, marker)
    return files


OLD_LOADER = """
import io, sys, torch
for kind, path in zip(sys.argv[1::2], sys.argv[2::2]):
    try:
        if kind == "program":
            data = torch.load(path, weights_only=True)  # the outer dict is plain data
            torch.export.load(io.BytesIO(data["program"]))
        else:
            torch.load(path, weights_only=False)
    except Exception:
        pass  # the payload ran already, or not at all: the marker says which
"""


def test_the_payloads_are_live_under_the_old_loader(tmp_path, program):
    """Each planted payload runs when the file is loaded as version 1 did, so that no
    marker under the new loaders proves them safe, not the payloads dead."""
    files = _old_files(tmp_path, program)
    command = [sys.executable, "-c", OLD_LOADER]
    for name, (path, _) in files.items():
        command += ["program" if name in PLACES else "pickle", str(path)]
    subprocess.run(command, cwd=tmp_path, capture_output=True, timeout=900, check=True)
    assert [name for name, (_, marker) in files.items() if not marker.exists()] == []


def test_no_loader_runs_an_old_checkpoints_payload(tmp_path, program, capsys):
    suite = tmp_path / "suite.yaml"
    suite.write_text(
        "tasks:\n  - scenario: fruits_poisons_multi\n    focal: [agent_0]\n"
        "    background: [random]\n    scripted: [planner]\n    episodes: 1\n"
    )
    multi = flatland_ma.parallel_env("fruits_poisons_multi")
    loaders = {
        "CheckpointPolicy": lambda p: CheckpointPolicy(p),
        "read_checkpoint": lambda p: read_checkpoint(p),
        "make_policy": lambda p: make_policy(str(p), multi, "agent_1"),
        "trained_with": lambda p: check_held_out(str(p), load_suite(str(suite))),
    }
    files = _old_files(tmp_path, program)
    for name, (path, _) in files.items():
        for road, load in loaders.items():
            with pytest.raises(ValueError) as refused:
                load(path)
            message = str(refused.value)
            assert str(path) in message and "old torch format" in message, (name, road)
            assert f"flatland-ma checkpoint convert {path}" in message, (name, road)
        argv = ["record", "fruits_poisons", "--policy", str(path), "--steps", "2"]
        assert main([*argv, "--out", str(tmp_path / "x.png")]) == 2
        assert "old torch format" in capsys.readouterr().err
        argv = ["evaluate", str(path), "--suite", str(suite), "--out", str(tmp_path / "out")]
        assert main(argv) == 2
        assert "old torch format" in capsys.readouterr().err
    assert not [marker for _, marker in files.values() if marker.exists()]


# -- data-only files that are not sound ------------------------------------------------------


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    agent = Agent(ENV.observation_space("agent_0"), ENV.action_space("agent_0"), hidden=8)
    optimizer = torch.optim.Adam(agent.parameters())
    return write_checkpoint(
        tmp_path_factory.mktemp("good") / "good.safetensors",
        agent,
        scenario="fruits_poisons",
        observation_space=ENV.observation_space("agent_0"),
        action_space=ENV.action_space("agent_0"),
        optimizer=optimizer.state_dict(),
        extra={"trained_with": ["self"]},
    )


def _raw(header: bytes | str, data: bytes = b"", length: int | None = None) -> bytes:
    header = header.encode() if isinstance(header, str) else header
    return struct.pack("<Q", len(header) if length is None else length) + header + data


def _with_tensor(entry: dict, data: bytes = b"\0" * 12) -> bytes:
    return _raw(json.dumps({"w": entry}), data)


BYTES = {
    "empty": (b"", "not a checkpoint"),
    "text": (b"just some notes\n", "not a checkpoint"),
    "huge_header_length": (_raw(b"{}", length=2**63), "more than the"),
    "header_past_the_end": (_raw(b"{}", length=100), "runs past the file's end"),
    "header_not_utf8": (_raw(b"{\xff}"), "its header"),
    "header_not_json": (_raw("{not json"), "its header"),
    "header_with_nan": (_raw('{"a": NaN}'), "NaN is not JSON"),
    "header_repeated_key": (_raw('{"a": 1, "a": 2}'), "repeated"),
    "header_a_list": (_raw("[]"), "not a JSON object"),
    "header_nested_deep": (_raw("[" * 100_000 + "]" * 100_000), "its header"),
    "metadata_not_strings": (_raw('{"__metadata__": {"a": 1}}'), "__metadata__"),
    "unknown_dtype": (
        _with_tensor({"dtype": "F128", "shape": [3], "data_offsets": [0, 12]}),
        "tensor 'w': dtype 'F128'",
    ),
    "negative_shape": (
        _with_tensor({"dtype": "F32", "shape": [-3], "data_offsets": [0, 12]}),
        "tensor 'w': shape and data_offsets",
    ),
    "offsets_that_do_not_fit": (
        _with_tensor({"dtype": "F32", "shape": [4], "data_offsets": [0, 12]}),
        "tensor 'w': data_offsets [0, 12] do not fit",
    ),
    "entry_with_extra_keys": (
        _with_tensor({"dtype": "F32", "shape": [3], "data_offsets": [0, 12], "x": 1}),
        "tensor 'w': needs exactly",
    ),
    "gap_in_the_data": (
        _raw(
            json.dumps(
                {
                    "a": {"dtype": "F32", "shape": [1], "data_offsets": [0, 4]},
                    "b": {"dtype": "F32", "shape": [1], "data_offsets": [8, 12]},
                }
            ),
            b"\0" * 12,
        ),
        "tensor 'b': its bytes overlap or leave a gap",
    ),
    "bytes_beyond_the_index": (_raw("{}", b"\0" * 5), "the index covers 0 bytes"),
    "plain_safetensors": (_raw("{}"), "no 'flatland_ma'"),
    # A header length whose first bytes read like a pickle's start (0x80, 0x02).
    "header_length_like_a_pickle": (_raw("{}" + " " * (0x280 - 2)), "no 'flatland_ma'"),
    "description_not_json": (
        _raw(json.dumps({"__metadata__": {"flatland_ma": "{oops"}})),
        "its description is not JSON",
    ),
}


@pytest.mark.parametrize("case", list(BYTES))
def test_bytes_that_are_not_a_checkpoint_get_a_located_error(tmp_path, case):
    blob, expected = BYTES[case]
    path = tmp_path / f"{case}.safetensors"
    path.write_bytes(blob)
    for load in (read_checkpoint, CheckpointPolicy):
        with pytest.raises(ValueError) as refused:
            load(path)
        assert str(path) in str(refused.value) and expected in str(refused.value), case


def _set(key, value):
    def change(description):
        description[key] = value

    return change


def _drop(key):
    return lambda description: description.pop(key) and None


def _arguments(**values):
    return lambda d: d["network"]["arguments"].update(values)


DESCRIPTIONS = {
    "wrong_format": (_set("format", "other"), "not a flatland_ma policy checkpoint"),
    "newer_version": (_set("version", 99), "checkpoint version 99, this flatland_ma reads 2"),
    "old_version": (_set("version", 1), "checkpoint version 1"),
    "no_scenario": (_drop("scenario"), "scenario: Field required"),
    "scenario_a_number": (_set("scenario", 7), "scenario: Input should be a valid string"),
    "trained_with_a_string": (_set("trained_with", "self"), "trained_with: Input should be"),
    "trained_with_numbers": (_set("trained_with", [1, 2]), "trained_with.0"),
    "action_sizes_zero": (_set("action_sizes", [0]), "action_sizes.0"),
    "action_sizes_negative": (_set("action_sizes", [-3]), "action_sizes.0"),
    "action_sizes_disagree": (_set("action_sizes", [4]), "action_sizes [4] disagree"),
    "unknown_entry": (_set("surprise", 1), "surprise: Extra inputs are not permitted"),
    "unknown_network": (
        lambda d: d["network"].update(kind="transformer"),
        "network: Input tag 'transformer'",
    ),
    "hidden_zero": (_arguments(hidden=0), "network.ppo.arguments.hidden"),
    "hidden_as_text": (_arguments(hidden="8"), "network.ppo.arguments.hidden"),
    "hidden_other_than_the_weights": (_arguments(hidden=9), "'model/body.0.weight': shape"),
    "output_too_wide_for_the_weights": (
        lambda d: d.update(
            action_sizes=[4], spaces={**d["spaces"], "action": {"type": "Discrete", "n": 4}}
        ),
        "'model/actor.weight': shape [3, 8], the described network needs [4, 8]",
    ),
    "observation_too_short": (
        lambda d: d["spaces"]["observation"].update(shape=[4, 4]),
        "network: the spaces and arguments make no ppo",
    ),
    "observation_huge": (
        lambda d: d["spaces"]["observation"].update(shape=[10**9, 4]),
        "spaces.observation.Box.shape.0",
    ),
    "observation_of_too_many_values": (
        lambda d: d["spaces"]["observation"].update(shape=[16384, 16384]),
        "an observation of 268,435,456 values; a checkpoint's network reads at most 4,194,304",
    ),
    "dict_entries_of_too_many_values_together": (
        lambda d: d["spaces"].update(
            observation={
                "type": "Dict",
                "spaces": {
                    k: {"type": "Box", "shape": [2048, 1025], "dtype": "float32"} for k in "ab"
                },
            }
        ),
        "an observation of 4,198,400 values",
    ),
    "optimizer_names_a_missing_tensor": (
        _set("optimizer", {"tensor": "optimizer/nothing"}),
        "optimizer: 'tensor'",
    ),
    "progress_negative_episodes": (
        _set("progress", {"episodes": -1, "cpu_seconds": 1.0, "wall_seconds": 1.0}),
        "progress.episodes",
    ),
    "progress_seconds_as_text": (
        _set("progress", {"episodes": 1, "cpu_seconds": "1.0", "wall_seconds": 1.0}),
        "progress.cpu_seconds",
    ),
    "progress_unknown_entry": (
        _set("progress", {"episodes": 1, "cpu_seconds": 1.0, "wall_seconds": 1.0, "x": 1}),
        "progress.x",
    ),
    "progress_no_stages": (
        _set("progress", {"episodes": 1, "cpu_seconds": 1.0, "wall_seconds": 1.0, "began": []}),
        "progress.began",
    ),
}


@pytest.mark.parametrize("case", list(DESCRIPTIONS))
def test_a_faulty_description_gets_a_located_error(tmp_path, good, case):
    change, expected = DESCRIPTIONS[case]
    path = tmp_path / f"{case}.safetensors"
    path.write_bytes(good.read_bytes())
    rewrite_description(path, change)
    with pytest.raises(ValueError) as refused:
        CheckpointPolicy(path)
    assert str(path) in str(refused.value) and expected in str(refused.value)
    with pytest.raises(ValueError, match=str(path)):
        make_policy(str(path), ENV, "agent_0")


def _tensors(change):
    def apply(weights):
        weights = dict(weights)
        change(weights)
        return weights

    return apply


TENSORS = {
    "missing_weight": (
        lambda w: w.pop("model/actor.bias"),
        "tensor 'model/actor.bias': missing",
    ),
    "wrong_shape": (
        lambda w: w.update({"model/actor.bias": torch.zeros(4)}),
        "tensor 'model/actor.bias': shape [4], the described network needs [3]",
    ),
    "half_precision": (
        lambda w: w.update({"model/actor.bias": torch.zeros(3, dtype=torch.float16)}),
        "tensor 'model/actor.bias': dtype torch.float16",
    ),
    "nan_weights": (
        lambda w: w.update({"model/actor.bias": torch.tensor([0.0, float("nan"), 0.0])}),
        "tensor 'model/actor.bias': holds NaN or infinite weights",
    ),
    "infinite_weights": (
        lambda w: w.update({"model/body.0.weight": w["model/body.0.weight"] / 0.0}),
        "tensor 'model/body.0.weight': holds NaN",
    ),
    "stray_tensor": (
        lambda w: w.update({"extra/thing": torch.zeros(2)}),
        "tensor 'extra/thing': not part of the checkpoint",
    ),
}


@pytest.mark.parametrize("case", list(TENSORS))
def test_tensors_that_do_not_fit_the_network_get_a_located_error(tmp_path, good, case):
    change, expected = TENSORS[case]
    path = tmp_path / f"{case}.safetensors"
    path.write_bytes(good.read_bytes())
    rewrite_description(path, lambda d: None, tensors=_tensors(change))
    with pytest.raises(ValueError) as refused:
        CheckpointPolicy(path)
    assert str(path) in str(refused.value) and expected in str(refused.value)


def test_described_shapes_are_checked_before_any_tensor_is_made(tmp_path, good, monkeypatch):
    """A small file may describe a huge observation: it is refused from its description
    alone, and a scenario's agent refuses another's spaces before the weights are read
    (the loader would otherwise probe the network with an observation of that shape)."""
    huge = tmp_path / "huge.safetensors"
    huge.write_bytes(good.read_bytes())
    rewrite_description(huge, lambda d: d["spaces"]["observation"].update(shape=[65536, 65536]))
    other = tmp_path / "other.safetensors"
    other.write_bytes(good.read_bytes())
    wide = "Box(0.0, 1.0, (2048, 2048), float32)"
    rewrite_description(
        other,
        lambda d: (
            d.update(observation_space=wide)
            or d["spaces"]["observation"].update(shape=[2048, 2048])
        ),
    )

    def no_tensor(*args, **kwargs):
        raise AssertionError("a tensor was made")

    import safetensors.torch

    monkeypatch.setattr(safetensors.torch, "load", no_tensor)
    monkeypatch.setattr(torch, "zeros", no_tensor)
    for load in (read_checkpoint, CheckpointPolicy, lambda p: make_policy(str(p), ENV, "agent_0")):
        with pytest.raises(ValueError, match="an observation of 4,294,967,296 values"):
            load(huge)
    with pytest.raises(
        ValueError, match=r"trained for the observation space Box\(0.0, 1.0, \(2048"
    ):
        make_policy(str(other), ENV, "agent_0")
    monkeypatch.undo()
    with pytest.raises(ValueError, match="the described network needs"):
        CheckpointPolicy(other)  # no scenario to compare with: its weights are read, then


def test_paths_that_are_not_regular_files_are_refused_before_reading(tmp_path, good):
    fifo = tmp_path / "fifo.safetensors"
    os.mkfifo(fifo)
    folder = tmp_path / "folder.safetensors"
    folder.mkdir()
    loop = tmp_path / "loop.safetensors"
    loop.symlink_to(tmp_path / "loop_back")
    (tmp_path / "loop_back").symlink_to(loop)
    big = tmp_path / "big.safetensors"
    with open(big, "wb") as file:  # sparse: no disk used
        file.truncate(tensor_file.MAX_FILE_BYTES + 1)
    linked = tmp_path / "linked.safetensors"
    linked.symlink_to(good)
    cases = {
        fifo: "not a regular file",
        folder: "not a regular file",
        Path("/dev/zero"): "not a regular file",
        loop: "cannot be read",
        big: "more than the 268435456 a checkpoint may hold",
        tmp_path / "absent.safetensors": "no such checkpoint file",
    }
    for path, expected in cases.items():
        for load in (read_checkpoint, CheckpointPolicy):
            with pytest.raises(ValueError) as refused:
                load(path)
            assert str(path) in str(refused.value) and expected in str(refused.value), path
    assert read_checkpoint(linked)["trained_with"] == ["self"]  # a symlink to a file is fine


def test_the_writer_refuses_what_the_reader_would(tmp_path):
    agent = Agent(ENV.observation_space("agent_0"), ENV.action_space("agent_0"), hidden=8)
    kwargs = {
        "scenario": "fruits_poisons",
        "observation_space": ENV.observation_space("agent_0"),
        "action_space": ENV.action_space("agent_0"),
    }
    with pytest.raises(ValueError, match="trained_with"):
        write_checkpoint(tmp_path / "a.safetensors", agent, **kwargs, extra={"trained_with": 3})
    with pytest.raises(ValueError, match="Out of range float values are not JSON"):
        write_checkpoint(tmp_path / "b.safetensors", agent, **kwargs, extra={"args": {"x": np.nan}})
    other = flatland_ma.parallel_env("coop_carry")
    with pytest.raises(ValueError, match="not those its description builds"):
        write_checkpoint(
            tmp_path / "c.safetensors",
            agent,
            **{**kwargs, "action_space": other.action_space("agent_0")},
        )
    assert not list(tmp_path.iterdir())
