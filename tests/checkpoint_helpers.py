"""Checkpoints as the baselines wrote them before the data-only format (version 1: a
``torch.save`` dict whose ``program`` is a ``torch.export`` archive), and pickled payloads
planted in each place that format lets one in. Used by the checkpoint tests and by
``benchmarks/checkpoint_load.py``; never by the package."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np
import torch

PLACES = ("pickled_weight", "sample_inputs", "opaque_constant")
"""Where inside the program's archive a payload can sit (the top-level pickle aside)."""


class Payload:
    """Unpickled, it runs ``open(marker, "w")``: the marker file stands for any code."""

    def __init__(self, marker: Path):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def exported(network: torch.nn.Module, example) -> bytes:
    """The ``torch.export`` archive of ``network`` on a batch like ``example`` (an array
    or a dict of arrays), its batch size left free, as version 1 saved it."""
    from torch.utils._pytree import tree_map

    def two(x) -> torch.Tensor:
        x = torch.as_tensor(np.ascontiguousarray(x[:1]))
        return torch.cat([x, x])

    inputs = tree_map(two, example)
    batch = torch.export.Dim("batch")
    shapes = (tree_map(lambda _: {0: batch}, inputs),)
    network.eval()
    program = torch.export.export(network, (inputs,), dynamic_shapes=shapes)
    buffer = io.BytesIO()
    torch.export.save(program, buffer)
    return buffer.getvalue()


def write_old_checkpoint(path: Path, program: bytes, **entries) -> Path:
    """A version 1 checkpoint: ``entries`` (scenario, spaces as text, model, args, ...)
    beside the program."""
    data = {"format": "flatland_ma.policy", "version": 1, "program": program, **entries}
    torch.save(data, path)
    return path


def _rewrite(archive: bytes, change) -> bytes:
    """``archive`` with ``change(name, data) -> data`` (None drops the member) applied to
    each member, plus the members ``change(None, None)`` returns."""
    source = zipfile.ZipFile(io.BytesIO(archive))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as target:
        for info in source.infolist():
            data = change(info.filename, source.read(info.filename))
            if data is not None:
                target.writestr(info.filename, data)
        for name, data in (change(None, None) or {}).items():
            target.writestr(name, data)
    return out.getvalue()


def planted(program: bytes, place: str, marker: Path) -> bytes:
    """``program`` with a payload in ``place`` (one of ``PLACES``)."""
    payload = io.BytesIO()
    torch.save(Payload(marker), payload)
    pickled = payload.getvalue()
    prefix = next(n for n in zipfile.ZipFile(io.BytesIO(program)).namelist()).split("/")[0]

    def change(name, data):
        if name is None:
            return {}
        if place == "sample_inputs" and name.endswith("data/sample_inputs/model.pt"):
            return pickled
        if place == "pickled_weight" and name.endswith("data/weights/model_weights_config.json"):
            config = json.loads(data)
            entry = next(iter(config["config"].values()))
            entry["use_pickle"] = True
            entry["path_name"] = "payload_weight"
            return json.dumps(config).encode()
        if place == "opaque_constant" and name.endswith(
            "data/constants/model_constants_config.json"
        ):
            config = json.loads(data)
            config["config"]["payload"] = {
                "path_name": "opaque_obj_0",
                "is_param": False,
                "use_pickle": True,
                "tensor_meta": None,
            }
            return json.dumps(config).encode()
        return data

    rewritten = _rewrite(program, change)
    extra = {
        "pickled_weight": f"{prefix}/data/weights/payload_weight",
        "opaque_constant": f"{prefix}/data/constants/opaque_obj_0",
    }
    if place in extra:
        member = pickled if place == "pickled_weight" else _plain_pickle(marker)
        rewritten = _rewrite(rewritten, lambda n, d: {extra[place]: member} if n is None else d)
    return rewritten


def _plain_pickle(marker: Path) -> bytes:
    import pickle

    return pickle.dumps(Payload(marker))


def rewrite_description(path: Path, change, tensors=None) -> Path:
    """Rewrite a data-only checkpoint: its description through ``change(description)``
    (edited in place, or a new one returned), its tensors through ``tensors(dict)`` if
    given. The test's way of making a checkpoint say something else."""
    from safetensors import safe_open
    from safetensors.torch import load_file, save_file

    with safe_open(str(path), "pt") as file:
        metadata = dict(file.metadata())
    description = json.loads(metadata["flatland_ma"])
    description = change(description) or description
    metadata["flatland_ma"] = json.dumps(description)
    weights = load_file(str(path))
    save_file(weights if tensors is None else tensors(weights), str(path), metadata)
    return path
