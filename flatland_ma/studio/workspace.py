"""What one studio serves: the shipped scenarios and the given folders' files, by
reference, with their checked specs and pictures (kept while their files are unchanged).

A reference is a shipped scenario's name (``fruits_poisons``) or ``N:NAME``, the file
NAME of the N-th given folder (``0:my_world.yaml``). Messages shown to pages name files
the same way, never by the server's paths (``public``).
"""

from __future__ import annotations

import collections
import hashlib
import threading
from pathlib import Path

from flatland_ma.scenario.errors import ScenarioError
from flatland_ma.scenario.loader import list_scenarios, load_scenario, scenario_dir
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.studio.config import StudioConfig
from flatland_ma.studio.folders import (
    CHECKPOINT_SUFFIXES,
    MAX_DEPTH,
    SCENARIO_SUFFIXES,
    FolderError,
    check_name,
    inside,
    list_files,
    read_file,
)
from flatland_ma.studio.scenarios import (
    Summary,
    encode,
    layout_picture,
    problem_json,
    spec_from_text,
)

CHECKPOINT_PREFIX = "checkpoint:"
"""A policy named ``checkpoint:NAME`` plays the file NAME of the checkpoint folder."""
MAX_DESCRIPTIONS = 1024
"""Checkpoint descriptions kept (a few kB each)."""


class Workspace:
    """The studio's scenarios and checkpoints; safe to use from several threads."""

    def __init__(self, config: StudioConfig):
        self.config = config
        self._pictures: collections.OrderedDict[tuple, bytes] = collections.OrderedDict()
        self._descriptions: collections.OrderedDict[tuple, dict | None] = collections.OrderedDict()
        self._lock = threading.Lock()
        roots: list[tuple[str, str]] = []
        for index, folder in enumerate(config.folders):
            roots += [(str(folder.resolve()), f"{index}:"), (str(folder), f"{index}:")]
        if config.checkpoints is not None:
            for form in (config.checkpoints.resolve(), config.checkpoints):
                roots.append((str(form), CHECKPOINT_PREFIX))
        package = Path(__file__).resolve().parents[1]
        roots += [(str(scenario_dir()), "scenarios"), (str(package), "flatland_ma")]
        self._roots = sorted(
            ((root.rstrip("/") + "/", name) for root, name in roots if root not in ("", ".")),
            key=lambda pair: -len(pair[0]),
        )

    def public(self, text: str) -> str:
        """``text`` with every path of a given folder, the checkpoint folder or the
        package named as the pages name them (``0:my_world.yaml``,
        ``checkpoint:ppo/seed_0.safetensors``), never by where they are on the server."""
        for root, name in self._roots:
            if root in text:
                text = text.replace(root, name if name.endswith(":") else name + "/")
        return text

    # -- references -------------------------------------------------------------------

    def folder(self, index: object) -> Path:
        """The given folder number ``index``."""
        folders = self.config.folders
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(folders):
            count = len(folders)
            raise FolderError(
                f"no folder {index!r}: the studio was given {count} folder(s)"
                + (f", numbered 0 to {count - 1}" if count else " (--scenarios DIR)")
            )
        return folders[index]

    def split(self, ref: object) -> tuple[Path | None, str]:
        """(folder, file name) of a folder's file, or (None, name) of a shipped one."""
        if not isinstance(ref, str) or not ref:
            raise FolderError("a scenario reference is a shipped name or N:FILE")
        if ":" not in ref:
            if ref not in list_scenarios():
                raise FolderError(f"no shipped scenario {ref!r}")
            return None, ref
        index, _, name = ref.partition(":")
        if not (index.isascii() and index.isdigit()) or len(index) > 3:
            raise FolderError(f"{ref!r}: a folder's file is N:FILE, N the folder's number")
        return self.folder(int(index)), check_name(name, SCENARIO_SUFFIXES)

    def text(self, ref: str) -> str:
        """The YAML text behind a reference."""
        folder, name = self.split(ref)
        if folder is None:
            path = Path(str(load_scenario(name).source))
            return path.read_text(encoding="utf-8")
        return read_file(folder, name, SCENARIO_SUFFIXES, self.config.limits.file_bytes)

    def spec(self, ref: str) -> ScenarioSpec:
        """The checked spec behind a reference (``ScenarioError`` or ``FolderError``)."""
        folder, name = self.split(ref)
        if folder is None:
            from flatland_ma.build.feasibility import check_scenario

            return check_scenario(name)
        return self.spec_of_text(self.text(ref), name, folder)

    def spec_of_text(self, text: str, name: str, folder: Path | None) -> ScenarioSpec:
        return spec_from_text(text, name, folder, self.config.limits.file_bytes)

    # -- listings ---------------------------------------------------------------------

    def refs(self) -> list[str]:
        """Every scenario served: the shipped ones, then each folder's files."""
        found = list(list_scenarios())
        for index, folder in enumerate(self.config.folders):
            found += [f"{index}:{name}" for name in list_files(folder, SCENARIO_SUFFIXES)]
        return found

    def entry(self, ref: str) -> dict:
        """The gallery's card of one scenario (its problems if it cannot be used)."""
        folder, name = self.split(ref)
        card: dict = {"ref": ref, "name": Path(name).stem, "folder": None}
        if folder is not None:
            card["folder"] = self.config.folders.index(folder)
        try:
            summary = Summary.of(self.spec(ref), name if folder is None else None)
        except ScenarioError as err:
            problems = [problem_json(p) for p in err.problems]
            for problem in problems:
                problem["source"] = self.public(str(problem["source"]))
                problem["message"] = self.public(str(problem["message"]))
            return {**card, "error": self.public(str(err)), "problems": problems}
        except FolderError as err:
            return {**card, "error": self.public(str(err)), "problems": []}
        return {**card, **summary.__dict__}

    def checkpoints(self) -> list[str]:
        """Checkpoint files under the checkpoint folder (a few folders deep)."""
        if self.config.checkpoints is None:
            return []
        return list_files(self.config.checkpoints, CHECKPOINT_SUFFIXES, MAX_DEPTH)

    def checkpoint(self, name: str) -> Path:
        """The path of a checkpoint inside the checkpoint folder."""
        if self.config.checkpoints is None:
            raise FolderError("no checkpoint folder was given (--checkpoints DIR)")
        return inside(self.config.checkpoints, check_name(name, CHECKPOINT_SUFFIXES, True))

    def fitting_checkpoints(self, env, agent: str) -> list[str]:
        """The checkpoints of the folder trained for ``agent``'s spaces (each file's
        description read once while the file is unchanged; unreadable ones left out)."""
        from flatland_ma.policies.checkpoint import agent_spaces, check_spaces, read_checkpoint

        fitting = []
        for name in self.checkpoints():
            path = self.checkpoint(name)
            try:
                stat = path.stat()
            except OSError:
                continue
            key = (name, stat.st_size, stat.st_mtime_ns)
            with self._lock:
                known = key in self._descriptions
                description = self._descriptions.get(key)
            if not known:
                try:
                    description = read_checkpoint(path)
                except ValueError:
                    description = None
                with self._lock:
                    self._descriptions[key] = description
                    while len(self._descriptions) > MAX_DESCRIPTIONS:
                        self._descriptions.popitem(last=False)
            if description is None:
                continue
            try:
                check_spaces(path, description, *agent_spaces(description, env, agent)[:2])
            except ValueError:
                continue
            fitting.append(name)
        return fitting

    # -- pictures ---------------------------------------------------------------------

    def picture(self, ref: str, seed: int) -> bytes:
        """A PNG of the layout behind ``ref`` at ``seed``, kept until its text changes."""
        text = self.text(ref)
        key = (ref, seed, hashlib.sha256(text.encode()).hexdigest())
        with self._lock:
            if key in self._pictures:
                self._pictures.move_to_end(key)
                return self._pictures[key]
        picture = encode(layout_picture(self.spec(ref), seed))
        with self._lock:
            self._pictures[key] = picture
            while len(self._pictures) > self.config.limits.pictures:
                self._pictures.popitem(last=False)
        return picture
