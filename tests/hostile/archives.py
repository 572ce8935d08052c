"""Checkpoints in the format flatland_ma wrote before issue 26, for the hostile corpus:
``torch.save`` of a dict whose ``program`` is a ``torch.export`` archive, made here with
torch and zip surgery (never with the package's own writer, which changes format), and
payloads that create a marker file if anything unpickles them.

The payload is an object whose ``__reduce__`` says "call ``open(MARKER, 'w')``": any
unpickler that honours it creates the marker in the case's folder. It is planted in each
place the old format lets a pickle in: the checkpoint's own pickle (top level, an extra
entry), and inside the program's archive a weight marked as pickled, the sample inputs,
a pickled tensor constant, an opaque object constant, and the legacy weights and
constants files. ``test_hostile_inputs`` checks that each planted program does run its
payload under ``torch.export.load``, so that a case that leaves no marker proves the
loader safe, not the payload dead.
"""

from __future__ import annotations

import functools
import io
import json
import pickle
import zipfile
from pathlib import Path

MARKER = "payload_ran"
"""The file a payload creates in the case's folder when it is unpickled."""
FORMAT, VERSION = "flatland_ma.policy", 1
"""What the old format's dict says it is."""
OBSERVATION = (64, 4)
"""``fruits_poisons``'s observation: one camera of 64 rays, colour and depth."""
OBSERVATION_SPACE = "Box(0.0, 1.0, (64, 4), float32)"
ACTION_SPACE = "Discrete(3)"
WEIGHTS_CONFIG = "data/weights/model_weights_config.json"
CONSTANTS_CONFIG = "data/constants/model_constants_config.json"
SAMPLE_INPUTS = "data/sample_inputs/model.pt"


class Payload:
    """Unpickled, it opens (creates) the marker file: the stand-in for any code."""

    def __init__(self, marker: Path):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def torch_saved(value) -> bytes:
    import torch

    buffer = io.BytesIO()
    torch.save(value, buffer)
    return buffer.getvalue()


@functools.cache
def program(outputs: int = 3) -> bytes:
    """A ``torch.export`` archive of a small network from a batch of ``fruits_poisons``
    observations to ``outputs`` logits (built once per test process: seconds)."""
    import torch

    class Network(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.linear = torch.nn.Linear(OBSERVATION[0] * OBSERVATION[1], outputs)

        def forward(self, observation):
            return self.linear(observation.flatten(1))

    batch = torch.export.Dim("batch")
    example = (torch.zeros(2, *OBSERVATION),)
    exported = torch.export.export(Network(), example, dynamic_shapes=({0: batch},))
    buffer = io.BytesIO()
    torch.export.save(exported, buffer)
    return buffer.getvalue()


def entries(archive: bytes) -> dict[str, bytes]:
    """The archive's files by name, without its top folder (``archive/``)."""
    with zipfile.ZipFile(io.BytesIO(archive)) as z:
        return {info.filename.split("/", 1)[1]: z.read(info) for info in z.infolist()}


def rebuilt(archive: bytes, changes: dict[str, bytes | None]) -> bytes:
    """``archive`` with files replaced or added (None: removed), stored uncompressed under
    the same top folder, as torch writes them."""
    files = entries(archive)
    top = zipfile.ZipFile(io.BytesIO(archive)).namelist()[0].split("/", 1)[0]
    for name, data in changes.items():
        if data is None:
            files.pop(name, None)
        else:
            files[name] = data
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as z:
        for name, data in files.items():
            z.writestr(f"{top}/{name}", data)
    return buffer.getvalue()


def _constant(path_name: str) -> bytes:
    meta = {"path_name": path_name, "is_param": False, "use_pickle": True, "tensor_meta": None}
    return json.dumps({"config": {"planted": meta}}).encode()


def planted(place: str, marker: Path) -> bytes:
    """The small network's archive with the payload planted at ``place`` (one of
    ``PLACES``)."""
    base = program()
    payload = Payload(marker)
    if place == "weight":
        config = json.loads(entries(base)[WEIGHTS_CONFIG])
        first = next(iter(config["config"].values()))
        first["use_pickle"] = True
        changes = {WEIGHTS_CONFIG: json.dumps(config).encode()}
        changes[f"data/weights/{first['path_name']}"] = torch_saved(payload)
    elif place == "sample_inputs":
        changes = {SAMPLE_INPUTS: torch_saved((payload,))}
    elif place == "tensor_constant":
        changes = {CONSTANTS_CONFIG: _constant("tensor_0")}
        changes["data/constants/tensor_0"] = torch_saved(payload)
    elif place == "opaque_constant":
        changes = {CONSTANTS_CONFIG: _constant("opaque_obj_0")}
        changes["data/constants/opaque_obj_0"] = pickle.dumps(payload)
    elif place == "legacy_weights":
        changes = {"data/weights/model.pt": torch_saved(payload)}
    elif place == "legacy_constants":
        changes = {"data/constants/model.pt": torch_saved(payload)}
    else:
        raise ValueError(f"no place {place!r}")
    return rebuilt(base, changes)


PLACES = (
    "weight",
    "sample_inputs",
    "tensor_constant",
    "opaque_constant",
    "legacy_weights",
    "legacy_constants",
)
"""Where inside a program's archive a payload is planted."""


def old_checkpoint(path: Path, **changes) -> Path:
    """A checkpoint of the old format for ``fruits_poisons`` (it played there before issue
    26), with entries replaced (``program=...``) or removed (``name=None``)."""
    data = {
        "format": FORMAT,
        "version": VERSION,
        "scenario": "fruits_poisons",
        "observation_space": OBSERVATION_SPACE,
        "action_space": ACTION_SPACE,
        "action_sizes": [3],
        "trained_with": ["self"],
        "program": program(),
    }
    for key, value in changes.items():
        if value is None:
            data.pop(key, None)
        else:
            data[key] = value
    path.write_bytes(torch_saved(data))
    return path


def payload_checkpoint(place: str, folder: Path, name: str = "policy.pt") -> Path:
    """An old-format checkpoint with the payload at ``place``: in its own pickle
    (``top_level``, ``extra_entry``) or in its program's archive (``PLACES``)."""
    marker = folder / MARKER
    if place == "top_level":
        (folder / name).write_bytes(torch_saved(Payload(marker)))
        return folder / name
    if place == "extra_entry":
        return old_checkpoint(folder / name, trainer={"optimiser": Payload(marker)})
    return old_checkpoint(folder / name, program=planted(place, marker))
