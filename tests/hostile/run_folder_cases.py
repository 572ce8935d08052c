"""Hostile ``lifelong report`` run folders: special files where a file belongs, numbers
that overflow, fields too long, text that is not UTF-8, values that are not finite or go
backwards.

Each must be refused with exit status 2 and the file named (``stream.json`` or the
``evaluations.csv`` at fault), no traceback, in bounded time and memory; a valid folder is
reported (status 0), its ``lifelong.json`` strict JSON (no bare ``NaN``).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

from tests.hostile.inputs import Command, Input, exits, fifo, sparse, symlink_loop

P = "issue 26: run folders"
RUN = "run"
STREAM = {"stream": "tiny", "tasks": ["a", "b"], "segments": [[0, 0, 100], [1, 100, 200]]}
STREAM["random"] = [0.0, 0.0]
CSV = "evaluations.csv"
HEAD = "step,task,episodes,mean_return\n"


def blocks(steps=(0, 100, 200), value: float = 1.0) -> str:
    rows = [f"{s},{t},4,{value + t + b:g}\n" for b, s in enumerate(steps) for t in (0, 1)]
    return HEAD + "".join(rows)


def valid(folder: Path, seeds: int = 2) -> Path:
    """A run of two tasks: a fine-tuning learner and the reference, ``seeds`` seeds each."""
    run = folder / RUN
    run.mkdir()
    (run / "stream.json").write_text(json.dumps(STREAM))
    for method in ("finetune", "reference"):
        for seed in range(seeds):
            (run / method / f"seed_{seed}").mkdir(parents=True)
            (run / method / f"seed_{seed}" / CSV).write_text(blocks(value=2.0 * seed))
    return run


def report(write: Callable[[Path], object], *options: str) -> Callable[[Path], Command]:
    """``lifelong report run`` after ``write(folder)`` spoils a valid run folder."""

    def make(folder: Path) -> Command:
        valid(folder)
        write(folder / RUN)
        return Command(["lifelong", "report", RUN, "--no-plot", *options])

    return make


def stream_text(text: str | bytes):
    def write(run: Path) -> None:
        path = run / "stream.json"
        path.write_bytes(text if isinstance(text, bytes) else text.encode())

    return write


def stream_with(**changes) -> Callable[[Path], None]:
    return stream_text(json.dumps({**STREAM, **changes}, allow_nan=True))


def csv_text(text: str | bytes):
    def write(run: Path) -> None:
        path = run / "finetune" / "seed_0" / CSV
        path.write_bytes(text if isinstance(text, bytes) else text.encode())

    return write


def replaced(name: str, special: Callable[[Path, str], object]) -> Callable[[Path], None]:
    """The file ``name`` (relative to the run) replaced by ``special(folder, name)``."""

    def write(run: Path) -> None:
        path = run / name
        path.unlink()
        special(path.parent, path.name)

    return write


def a_folder(folder: Path, name: str) -> None:
    (folder / name).mkdir()


def dev_zero(folder: Path, name: str) -> None:
    os.symlink("/dev/zero", folder / name)


def strict_json(folder: Path) -> str | None:
    """A complaint if ``lifelong.json`` is missing or not strict JSON (bare NaN)."""
    path = folder / RUN / "lifelong.json"
    if not path.is_file():
        return "no lifelong.json was written"

    def refuse(token: str):
        raise ValueError(f"bare {token} in lifelong.json")

    try:
        json.loads(path.read_text(), parse_constant=refuse)
    except ValueError as err:
        return str(err)
    return None


def refused(name: str, write, *words: str, options=(), **more) -> Input:
    return Input(name, report(write, *options), exits(2, *words), **more)


SEED_CSV = f"finetune/seed_0/{CSV}"
CASES = [
    Input(
        "valid_two_seeds",
        lambda folder: (valid(folder), Command(["lifelong", "report", RUN, "--no-plot"]))[1],
        exits(0, "finetune"),
        after=strict_json,
    ),
    Input(
        "valid_one_seed_json_strict",
        lambda folder: (valid(folder, 1), Command(["lifelong", "report", RUN, "--no-plot"]))[1],
        exits(0, "finetune"),
        after=strict_json,
    ),
    Input(
        "folder_missing",
        lambda folder: Command(["lifelong", "report", "nowhere", "--no-plot"]),
        exits(2, "nowhere"),
    ),
    Input(
        "folder_is_a_file",
        lambda folder: ((folder / RUN).write_text("x"), Command(["lifelong", "report", RUN]))[1],
        exits(2, RUN),
    ),
    refused("stream_json_a_folder", replaced("stream.json", a_folder), "stream.json"),
    refused("stream_json_symlink_loop", replaced("stream.json", symlink_loop), "stream.json"),
    # waits on the FIFO until the time limit while the fault is there
    refused("stream_json_fifo", replaced("stream.json", fifo), "stream.json", slow=True),
    refused("stream_json_dev_zero", replaced("stream.json", dev_zero), "stream.json"),
    refused("stream_json_sparse_2_gib", replaced("stream.json", sparse), "stream.json"),
    refused("stream_json_not_utf8", stream_text(b'{"tasks": ["\xe9"]}'), "stream.json"),
    refused("stream_json_nested_100k", stream_text("[" * 100_000 + "]" * 100_000), "stream.json"),
    refused("stream_json_a_list", stream_text("[1, 2]"), "stream.json"),
    refused(
        "stream_random_1e999",
        stream_text(json.dumps(STREAM).replace("0.0]", "1e999]")),
        "stream.json",
        "random",
    ),
    refused("stream_random_nan", stream_with(random=[float("nan"), 0.0]), "stream.json", "random"),
    refused(
        "stream_segments_400_digits",
        stream_with(segments=[[0, 0, 10**400], [1, 10**400, 10**401]]),
        "stream.json",
        "segments",
    ),
    refused("stream_segment_task_5", stream_with(segments=[[5, 0, 100]]), "stream.json"),
    refused("csv_a_folder", replaced(SEED_CSV, a_folder), CSV),
    refused("csv_dev_zero", replaced(SEED_CSV, dev_zero), CSV),
    refused("csv_fifo", replaced(SEED_CSV, fifo), CSV),
    refused("csv_symlink_loop", replaced(SEED_CSV, symlink_loop), CSV),
    refused("csv_sparse_2_gib", replaced(SEED_CSV, sparse), CSV),
    refused("csv_field_200k", csv_text(HEAD + f"0,0,4,{'1' * 200_000}\n"), CSV),
    refused("csv_step_1e999", csv_text(HEAD + "1e999,0,4,1\n1e999,1,4,1\n"), CSV),
    refused("csv_step_400_digits", csv_text(blocks(steps=(0, 10**400))), CSV),
    refused("csv_return_nan", csv_text(HEAD + "0,0,4,nan\n0,1,4,1\n"), CSV),
    refused("csv_not_utf8", csv_text(HEAD.encode() + b"0,0,4,1\xe9\n"), CSV),
    refused("csv_nul_bytes", csv_text(HEAD + "0,0\x00,4,1\n"), CSV),
    refused("csv_steps_backwards", csv_text(blocks(steps=(200, 100, 0))), CSV),
    refused("csv_header_wrong", csv_text("a,b,c\n1,2,3\n"), CSV),
    refused(
        "seed_folder_not_a_number",
        lambda run: (run / "finetune" / "seed_0").rename(run / "finetune" / "seed_x"),
        "seed_x",
    ),
    refused(
        "out_an_existing_file",
        lambda run: (run.parent / "taken").write_text("mine\n"),
        "taken",
        options=("--out", "taken"),
    ),
]
