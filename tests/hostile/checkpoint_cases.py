"""Hostile checkpoints: files given where a trained policy belongs.

Every one must be refused before anything in it runs: the command exits with status 2
naming the file (the API raises ``ValueError`` naming it, a stream or suite gives a
located error), and the payload's marker never appears. Old-format checkpoints (a
``torch.save`` dict with a ``torch.export`` program) are refused whatever they hold,
with a word on how to convert a file you trust; payloads sit in each place that format
lets a pickle in (``archives.PLACES``, the top-level pickle, an extra entry), and reach
the loaders by each road: ``record --policy``, ``evaluate``, ``evaluate --crossplay``,
``play --others``, a stream's or a suite's background, ``CheckpointPolicy``.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from pathlib import Path

from tests.hostile import archives
from tests.hostile.inputs import (
    TORCH,
    Command,
    Input,
    Snippet,
    exits,
    fifo,
    located,
    raises,
    sparse,
    symlink_loop,
)

NAME = "policy.pt"
P = "issue 26: checkpoints"
"""The reason of the rows that wait for the data-only checkpoint format."""

SUITE = """tasks:
  - scenario: fruits_poisons_multi
    focal: [agent_0]
    background: [{background}]
    scripted: [planner]
    episodes: 1
    overrides: {{episode: {{max_steps: 4}}}}
"""
STREAM = """tasks:
  - name: first
    scenario: fruits_poisons_multi
    focal: [agent_0]
    background: {background}
    steps: 10
"""
STREAM_ENV = """from flatland_ma.lifelong.envs import StreamParallelEnv
env = StreamParallelEnv(folder / "stream.yaml")
env.reset(seed=0)
"""


# -- the roads to a loader: each takes the checkpoint's path, returns what to run ----------


def by_record(path: Path) -> Command:
    return Command(["record", "fruits_poisons", "--policy", path.name, "--steps", "2"])


def by_evaluate(path: Path) -> Command:
    (path.parent / "suite.yaml").write_text(SUITE.format(background="random"))
    return Command(["evaluate", path.name, "--suite", "suite.yaml", "--no-plot", "--out", "out"])


def by_crossplay(path: Path) -> Command:
    argv = ["evaluate", "--crossplay", path.name, "random", "--episodes", "1", "--no-plot"]
    return Command(argv + ["--out", "out"])


def by_play(path: Path) -> Command:
    argv = ["play", "fruits_poisons_multi", "--others", path.name, "--keys", "space*2"]
    return Command(argv + ["--scores", "scores.csv"], {"SDL_VIDEODRIVER": "dummy"})


def by_suite_background(path: Path) -> Command:
    (path.parent / "suite.yaml").write_text(SUITE.format(background=path))
    return Command(["evaluate", "random", "--suite", "suite.yaml", "--no-plot", "--out", "out"])


def by_stream_background(path: Path) -> Snippet:
    (path.parent / "stream.yaml").write_text(STREAM.format(background=path))
    return Snippet(STREAM_ENV)


def by_api(path: Path) -> Snippet:
    code = "from flatland_ma.policies.checkpoint import CheckpointPolicy\n"
    return Snippet(code + f"CheckpointPolicy(folder / {path.name!r})")


ROADS: dict[str, Callable] = {
    "record": by_record,
    "evaluate": by_evaluate,
    "crossplay": by_crossplay,
    "play": by_play,
    "suite_background": by_suite_background,
    "stream_background": by_stream_background,
    "api": by_api,
}


def refused(road: str):
    """What refusing the checkpoint looks like on ``road``."""
    if road == "api":
        return raises("ValueError", NAME)
    if road == "stream_background":
        return located("tasks[0].background", NAME)
    return exits(2, NAME)


def through(road: str, write: Callable[[Path], Path]) -> Callable[[Path], Command | Snippet]:
    return lambda folder: ROADS[road](write(folder))


def payload(place: str, road: str, **options) -> Input:
    write = lambda folder: archives.payload_checkpoint(place, folder, NAME)  # noqa: E731
    name = f"payload_{place}_via_{road}"
    return Input(name, through(road, write), refused(road), warm=TORCH, **options)


def malformed(name: str, write: Callable[[Path], Path], road: str = "record", **options) -> Input:
    return Input(name, through(road, write), refused(road), warm=TORCH, **options)


# -- files that are not checkpoints ---------------------------------------------------------


def written(data: bytes | Callable[[], bytes]) -> Callable[[Path], Path]:
    def write(folder: Path) -> Path:
        (folder / NAME).write_bytes(data() if callable(data) else data)
        return folder / NAME

    return write


def old(**changes) -> Callable[[Path], Path]:
    """An old-format checkpoint with ``changes`` (a callable value is called first)."""

    def write(folder: Path) -> Path:
        made = {key: value() if callable(value) else value for key, value in changes.items()}
        return archives.old_checkpoint(folder / NAME, **made)

    return write


def truncated(folder: Path) -> Path:
    whole = archives.old_checkpoint(folder / NAME).read_bytes()
    (folder / NAME).write_bytes(whole[: len(whole) // 2])
    return folder / NAME


def foreign_zip() -> bytes:
    import io
    import zipfile

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as z:
        z.writestr("readme.txt", "not a policy")
    return buffer.getvalue()


def header(length: int, text: bytes) -> bytes:
    """A safetensors-like start: the header's length (8 bytes, little-endian), then it."""
    return struct.pack("<Q", length) + text


def at(target: str) -> Callable[[Path], Path]:
    def link(folder: Path) -> Path:
        (folder / NAME).symlink_to(target)
        return folder / NAME

    return link


def directory(folder: Path) -> Path:
    (folder / NAME).mkdir()
    return folder / NAME


DEEP_JSON = b"[" * 100_000 + b"]" * 100_000
OFFSETS = b'{"w": {"dtype": "F32", "shape": [1000000000], "data_offsets": [0, 4000000000]}}'

MALFORMED = [
    malformed("text_file", written(b"hello, I am a policy\n")),
    malformed("empty_file", written(b"")),
    malformed("random_bytes", written(lambda: bytes(range(256)) * 4096)),
    malformed("truncated_archive", truncated),
    malformed("foreign_zip", written(foreign_zip)),
    malformed("header_length_2_to_63", written(header(1 << 63, b"{}"))),
    malformed("header_longer_than_file", written(header(1000, b'{"a": '))),
    malformed("header_not_json", written(header(10, b"not json!!"))),
    malformed("header_json_nested_100k", written(header(len(DEEP_JSON), DEEP_JSON))),
    malformed("header_offsets_beyond_file", written(header(len(OFFSETS), OFFSETS))),
    malformed("directory", directory),
    malformed("fifo", lambda folder: fifo(folder, NAME)),
    malformed("dev_zero", at("/dev/zero")),
    malformed("symlink_loop", lambda folder: symlink_loop(folder, NAME)),
    malformed("missing_file", lambda folder: folder / NAME),
    malformed("sparse_2_gib", lambda folder: sparse(folder, NAME)),
    # the old format: refused whatever it holds, with how to convert a file you trust
    Input("old_format_valid", through("record", old()), exits(2, NAME, "convert"), warm=TORCH),
    malformed("old_without_program", old(program=None)),
    malformed("old_program_an_int", old(program=7)),
    malformed("old_program_garbage", old(program=b"\x00garbage" * 100)),
    malformed("old_format_other", old(format="someone.else")),
    malformed("old_version_99", old(version=99)),
    malformed("old_scenario_an_int", old(scenario=5)),
    malformed("old_action_sizes_zero", old(action_sizes=[0])),
    malformed("old_action_sizes_negative", old(action_sizes=[-3])),
    malformed("old_action_sizes_too_many", old(action_sizes=[1, 1, 1])),
    malformed("old_output_of_wrong_shape", old(program=lambda: archives.program(5))),
    malformed("old_trained_with_a_string", old(trained_with="self"), road="evaluate"),
    malformed("old_trained_with_an_int", old(trained_with=3), road="evaluate"),
    malformed("old_missing_file_in_suite", lambda folder: folder / NAME, road="suite_background"),
    malformed("old_missing_file_in_stream", lambda folder: folder / NAME, road="stream_background"),
    malformed("text_file_in_crossplay", written(b"hello"), road="crossplay"),
    malformed("dev_zero_via_api", at("/dev/zero"), road="api"),
]

FAST_PLACES = ("top_level", "extra_entry", *archives.PLACES)
"""Every place, through ``record``; the two archive places seen most (a weight and the
sample inputs) through every road; the rest of the cross product in the slow run."""
PAYLOADS = [
    *[payload(place, "record") for place in FAST_PLACES],
    *[
        payload(place, road)
        for place in ("weight", "sample_inputs")
        for road in ROADS
        if road != "record"
    ],
    *[
        payload(place, road, slow=True)
        for place in FAST_PLACES
        if place not in ("weight", "sample_inputs")
        for road in ROADS
        if road != "record"
    ],
]

CASES = [*PAYLOADS, *MALFORMED]
