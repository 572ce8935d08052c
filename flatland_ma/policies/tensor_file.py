"""Tensors and JSON in one safetensors file, read as data only, with limits.

A safetensors file is an 8-byte little-endian header length, a JSON header (each tensor's
dtype, shape and byte range, and ``__metadata__``, a map of strings) and the tensors' bytes.
``read_tensor_file`` checks all of it before any tensor is made: only regular files (not
FIFOs, devices, directories or symlink loops), at most ``MAX_FILE_BYTES``, a header of at
most ``MAX_HEADER_BYTES`` of strict JSON (no NaN, no repeated key), known dtypes, byte
ranges that tile the data exactly. Every fault is a ``ValueError`` naming the file and the
entry. Nothing in the file is unpickled or run.

``encode_tree`` / ``decode_tree`` keep nested dicts, lists and tuples of tensors and plain
values (an optimiser's state) as JSON with each tensor named, stored beside the others.
"""

from __future__ import annotations

import json
import math
import os
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any

MAX_FILE_BYTES = 256 * 2**20
"""A checkpoint bigger than this is refused before it is read."""
MAX_HEADER_BYTES = 2**20
"""The JSON header (the tensors' index and the metadata) may hold at most this."""
MAX_DIMENSIONS = 8
DTYPES = {"F64": 8, "F32": 4, "F16": 2, "BF16": 2, "I64": 8, "I32": 4, "I16": 2, "I8": 1}
DTYPES |= {"U8": 1, "BOOL": 1}
"""The dtypes a tensor may have, and their sizes in bytes."""
ZIP = b"PK\x03\x04"
PICKLES = (b"\x80\x02", b"\x80\x03", b"\x80\x04", b"\x80\x05")
"""How the files ``torch.save`` writes begin: a zip archive, or a bare pickle (protocol 2
to 5). Read as a safetensors header length, either is more than ``MAX_HEADER_BYTES``."""


class TensorFileError(ValueError):
    """A file that is not a sound tensor file; the message names it and the entry."""


def read_tensor_file(
    path: str | Path, *, tensors: bool = True, check: Callable[[dict[str, str]], Any] = dict
) -> tuple[Any, dict]:
    """``check(metadata)`` (the file's metadata, a map of strings; checked before any
    tensor is made) and, if ``tensors``, the tensors by name (torch); else only their
    index (name -> dtype, shape)."""
    path = Path(path)
    blob, size = read_regular_file(path, header_only=not tensors)
    length = int.from_bytes(blob[:8], "little")
    if (len(blob) < 8 or length > MAX_HEADER_BYTES) and written_by_torch_save(blob):
        raise TensorFileError(f"{path}: {OLD_FORMAT_HINT.format(path=path)}")
    if len(blob) < 8:
        raise TensorFileError(f"{path}: not a checkpoint (only {len(blob)} bytes)")
    if length > MAX_HEADER_BYTES:
        raise TensorFileError(
            f"{path}: not a checkpoint (a header of {length} bytes, more than the "
            f"{MAX_HEADER_BYTES} allowed)"
        )
    header = _parse_header(path, blob[8 : 8 + length], length)
    metadata = header.pop("__metadata__", {})
    if not isinstance(metadata, dict) or not all(isinstance(v, str) for v in metadata.values()):
        raise TensorFileError(f"{path}: __metadata__: not a map of strings")
    index = _check_index(path, header, size - 8 - length)
    checked = check(metadata)
    if not tensors:
        return checked, index
    from safetensors.torch import load

    try:
        return checked, load(bytes(blob))
    except Exception as err:  # checked above; say so if the library still disagrees
        raise TensorFileError(f"{path}: the tensors cannot be read ({err})") from None


def written_by_torch_save(start: bytes) -> bool:
    """Whether a file beginning with ``start`` is a zip archive or a pickle, as the old
    checkpoints were (asked only when ``start`` is no safetensors header)."""
    return start[:4] == ZIP or start[:2] in PICKLES


OLD_FORMAT_HINT = (
    "a checkpoint in the old torch format, which can run code when it is loaded; this "
    "flatland_ma reads only data (safetensors weights and a JSON description). If you "
    "trust where the file came from, convert it: flatland-ma checkpoint convert {path} "
    "NEW.safetensors"
)


def read_regular_file(path: Path, header_only: bool = False) -> tuple[bytes, int]:
    """The file's bytes (with ``header_only``, enough for the header) and its size, if it
    is a regular file within ``MAX_FILE_BYTES``."""
    try:
        info = os.stat(path)  # follows symlinks; a loop raises ELOOP
    except FileNotFoundError:
        raise TensorFileError(f"{path}: no such checkpoint file") from None
    except OSError as err:
        raise TensorFileError(f"{path}: cannot be read ({err.strerror})") from None
    if not stat.S_ISREG(info.st_mode):
        raise TensorFileError(f"{path}: not a regular file")
    if info.st_size > MAX_FILE_BYTES:
        raise TensorFileError(
            f"{path}: {info.st_size} bytes, more than the {MAX_FILE_BYTES} a checkpoint may hold"
        )
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as err:
        raise TensorFileError(f"{path}: cannot be read ({err.strerror})") from None
    with os.fdopen(fd, "rb") as file:
        now = os.fstat(file.fileno())  # the file opened may not be the one looked at
        if not stat.S_ISREG(now.st_mode) or now.st_size > MAX_FILE_BYTES:
            raise TensorFileError(f"{path}: not a regular file of at most {MAX_FILE_BYTES} bytes")
        if header_only:
            start = file.read(8)
            length = int.from_bytes(start, "little") if len(start) == 8 else 0
            return start + file.read(min(length, MAX_HEADER_BYTES)), now.st_size
        blob = file.read(MAX_FILE_BYTES + 1)
    if len(blob) > MAX_FILE_BYTES:
        raise TensorFileError(f"{path}: grew past {MAX_FILE_BYTES} bytes while it was read")
    return blob, len(blob)


def _no_constant(name: str):
    raise ValueError(f"{name} is not JSON")


def _unique_keys(pairs: list) -> dict:
    keys = [key for key, _ in pairs]
    if len(set(keys)) != len(keys):
        raise ValueError(f"the key {next(k for k in keys if keys.count(k) > 1)!r} is repeated")
    return dict(pairs)


def strict_json(text: str) -> Any:
    """``json.loads`` refusing NaN and infinities and repeated keys."""
    return json.loads(text, parse_constant=_no_constant, object_pairs_hook=_unique_keys)


def _parse_header(path: Path, raw: bytes, length: int) -> dict:
    if len(raw) != length:
        raise TensorFileError(f"{path}: not a checkpoint (the header runs past the file's end)")
    try:
        header = strict_json(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as err:
        raise TensorFileError(f"{path}: not a checkpoint (its header: {err})") from None
    if not isinstance(header, dict):
        raise TensorFileError(f"{path}: not a checkpoint (its header is not a JSON object)")
    return header


def _check_index(path: Path, header: dict, data_bytes: int) -> dict:
    """Each tensor's (dtype, shape), once its entry is checked; the byte ranges must
    tile the ``data_bytes`` after the header exactly."""
    index, ranges = {}, []
    for name, entry in header.items():
        where = f"{path}: tensor {name!r}"
        if not isinstance(entry, dict) or set(entry) != {"dtype", "shape", "data_offsets"}:
            raise TensorFileError(f"{where}: needs exactly dtype, shape and data_offsets")
        dtype, shape, offsets = entry["dtype"], entry["shape"], entry["data_offsets"]
        if dtype not in DTYPES:
            raise TensorFileError(f"{where}: dtype {dtype!r}, not one of {', '.join(DTYPES)}")
        if not _ints(shape, MAX_DIMENSIONS) or not _ints(offsets, 2, exactly=True):
            raise TensorFileError(
                f"{where}: shape and data_offsets must be lists of non-negative integers"
            )
        begin, end = offsets
        if end < begin or end - begin != math.prod(shape) * DTYPES[dtype]:
            raise TensorFileError(f"{where}: data_offsets {offsets} do not fit {dtype} {shape}")
        index[name] = (dtype, tuple(shape))
        ranges.append((begin, end, name))
    position = 0
    for begin, end, name in sorted(ranges):
        if begin != position:
            raise TensorFileError(f"{path}: tensor {name!r}: its bytes overlap or leave a gap")
        position = end
    if position != data_bytes:
        raise TensorFileError(
            f"{path}: not a checkpoint (the index covers {position} bytes of data, the file "
            f"holds {data_bytes})"
        )
    return index


def _ints(value: Any, most: int, exactly: bool = False) -> bool:
    return (
        isinstance(value, list)
        and (len(value) == most if exactly else len(value) <= most)
        and all(isinstance(x, int) and not isinstance(x, bool) and 0 <= x < 2**62 for x in value)
    )


def write_tensor_file(path: Path, tensors: dict, metadata: dict[str, str]) -> None:
    """Write ``tensors`` (name -> torch tensor) and ``metadata`` to a temporary file and
    move it into place, so a reader never sees half a file."""
    from safetensors.torch import save_file

    part = path.with_name(path.name + ".part")
    save_file({k: t.detach().cpu().contiguous() for k, t in tensors.items()}, part, metadata)
    os.replace(part, path)


# -- nested state as JSON and named tensors ---------------------------------------------


def encode_tree(tree: Any, prefix: str, tensors: dict) -> Any:
    """``tree`` as JSON: dicts as ``{"dict": [[key, value], ...]}`` (keys may be ints),
    tuples as ``{"tuple": [...]}``, a tensor as ``{"tensor": name}`` with the tensor put in
    ``tensors`` under ``prefix`` + its path, non-finite floats as ``{"float": "inf"}``."""
    import torch

    if isinstance(tree, torch.Tensor):
        tensors[prefix] = tree
        return {"tensor": prefix}
    if isinstance(tree, dict):
        return {"dict": [[k, encode_tree(v, f"{prefix}/{k}", tensors)] for k, v in tree.items()]}
    if isinstance(tree, (list, tuple)):
        items = [encode_tree(v, f"{prefix}/{i}", tensors) for i, v in enumerate(tree)]
        return items if isinstance(tree, list) else {"tuple": items}
    if isinstance(tree, float) and not math.isfinite(tree):
        return {"float": str(tree)}
    if tree is None or isinstance(tree, (bool, int, float, str)):
        return tree
    raise TypeError(f"{prefix}: a {type(tree).__name__} cannot be kept as data")


def decode_tree(code: Any, tensors: dict, where: str) -> Any:
    """The tree ``encode_tree`` wrote; ``ValueError`` naming ``where`` for anything else."""
    if isinstance(code, list):
        return [decode_tree(v, tensors, where) for v in code]
    if not isinstance(code, dict):
        return code
    if len(code) != 1:
        raise ValueError(f"{where}: an object must be one of dict, tuple, tensor or float")
    ((tag, value),) = code.items()
    if tag == "tensor" and isinstance(value, str) and value in tensors:
        return tensors[value]
    if tag == "tuple" and isinstance(value, list):
        return tuple(decode_tree(v, tensors, where) for v in value)
    if tag == "float" and value in ("inf", "-inf", "nan"):
        return float(value)
    if tag == "dict" and isinstance(value, list):
        if not all(
            isinstance(p, list) and len(p) == 2 and isinstance(p[0], (int, str)) for p in value
        ):
            raise ValueError(f"{where}: a dict is a list of [key, value] pairs")
        return {k: decode_tree(v, tensors, where) for k, v in value}
    raise ValueError(f"{where}: {tag!r}: not a dict, tuple, float or a tensor of the file")
