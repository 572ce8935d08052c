"""Markdown helpers shared by the generated catalogue pages (scenarios, streams, suites)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np


def header_comment(path: Path) -> list[str]:
    """The file's leading comment block, ``# `` stripped (blank comment lines kept as "")."""
    lines = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        lines.append(line[1:].removeprefix(" ").rstrip())
    return lines


def body_of(comment: list[str]) -> list[str]:
    """The comment without its name: the first paragraph loses its ``name:`` prefix."""
    if not comment:
        return []
    first, rest = comment[0], comment[1:]
    lead = first.split(":", 1)[-1].strip()
    return [lead[:1].upper() + lead[1:], *rest]


def split_scores(comment: list[str]) -> tuple[list[str], list[str]]:
    """The comment's prose and its reference scores: the scores start at the first line that
    names them ("Scores, mean ± std ...", "Scores of the red team ...")."""
    for i, line in enumerate(comment):
        if line.startswith("Scores"):
            return comment[:i], comment[i:]
    return comment, []


def paragraphs(lines: list[str]) -> str:
    """Comment lines as Markdown paragraphs (a blank line between paragraphs)."""
    text = "\n".join(lines).strip()
    return escape_text(text)


def escape_text(text: str) -> str:
    """Markdown-safe prose: characters that would start markup are escaped."""
    for mark in ("\\", "*", "<", "[", "]", "|", "`"):
        text = text.replace(mark, "\\" + mark)
    return text


def cell(value: object) -> str:
    """A table cell: pipes escaped, line breaks removed."""
    return str(value).replace("|", "\\|").replace("\n", " ")


def table(headers: list[str], rows: list[list[object]]) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)


def code(value: object) -> str:
    """Inline code that survives backticks in the value."""
    text = str(value).replace("\n", " ")
    fence = "``" if "`" in text else "`"
    return f"{fence}{text}{fence}"


def compact(spec, drop: tuple[str, ...] = ()) -> str:
    """A spec's fields that differ from their defaults, as ``key=value`` pairs."""
    data = spec.model_dump(exclude_defaults=True, mode="json")
    pairs = [f"{k}={_short(v)}" for k, v in data.items() if k not in drop]
    return ", ".join(pairs) if pairs else "defaults"


def _short(value: object) -> str:
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_short(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    return str(value)


def space_rows(space) -> list[list[str]]:
    """One row per observation entry: key, shape, dtype and the range of its values."""
    if hasattr(space, "spaces") and isinstance(space.spaces, dict):
        return [[code(k), *_box(s)] for k, s in space.spaces.items()]
    return [["(the whole observation)", *_box(space)]]


def _box(space) -> list[str]:
    shape = getattr(space, "shape", None)
    dtype = getattr(space, "dtype", None)
    low, high = getattr(space, "low", None), getattr(space, "high", None)
    if low is None or high is None:
        return [code(shape), str(dtype), code(space)]
    lows, highs = np.unique(low), np.unique(high)
    span = f"{_num(lows.min())} to {_num(highs.max())}"
    if len(lows) > 1 or len(highs) > 1:
        span += " (per entry)"
    return [code(shape), str(dtype), span]


def _num(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def relative(target: Path, page_dir: Path) -> str:
    """``target`` as a path relative to the folder of the page that names it."""
    return Path(os.path.relpath(target, page_dir)).as_posix()


def picture(path: Path, page_dir: Path, alt: str, width: int = 360) -> list[str]:
    """An image directive (the pictures are drawn large; pages show them smaller)."""
    return [
        f"```{{image}} {relative(path, page_dir)}",
        f":alt: {alt}",
        f":width: {width}px",
        "```",
        "",
    ]


def literal_file(path: Path, page_dir: Path, language: str = "yaml") -> str:
    return f"```{{literalinclude}} {relative(path, page_dir)}\n:language: {language}\n```"


def write_if_changed(path: Path, text: str) -> bool:
    """Write ``text`` unless the file already holds it (Sphinx rereads changed files only)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_file() and path.read_text(encoding="utf-8") == text:
        return False
    path.write_text(text, encoding="utf-8")
    return True
