"""Scenario text from a client (or a folder) to a checked spec, and pictures of it.

Text is read as the loader reads a file (``scenario.yaml_reader``, ``loader.merge`` and
``loader.validate``, then ``build.check_scenario``), so every fault comes back as the
loader's located ``Problem``: the line, the key path, the message. One thing is stricter
than files on disk: ``extends`` may name a shipped scenario or a file of the same folder,
never a path, so text from a browser cannot make the server read any other file.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from flatland_ma.build.feasibility import check_scenario
from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.envs.registration import gym_id
from flatland_ma.render.renderer import Renderer
from flatland_ma.scenario.errors import Marks, Problem, ScenarioError, format_path, locate
from flatland_ma.scenario.loader import list_scenarios, merge, read_raw, validate
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.scenario.yaml_reader import parse_yaml
from flatland_ma.studio.folders import SCENARIO_SUFFIXES, FolderError, read_file

MAX_EXTENDS = 8
"""Files a chain of ``extends`` may pass through."""


def problem_json(problem: Problem) -> dict:
    """A located problem as the pages show it."""
    return {
        "source": problem.source,
        "line": problem.line,
        "path": format_path(problem.path),
        "message": problem.message,
    }


def _fault(source: str, marks: Marks, message: str) -> ScenarioError:
    return ScenarioError([locate(marks, ("extends",), message, source)])


def _raw(text: str, source: str, folder: Path | None, limit: int, chain: tuple) -> tuple:
    """Plain data and marks of scenario ``text``, its ``extends`` chain merged in."""
    marks: Marks = {}
    raw = parse_yaml(text, source, marks)
    base = raw.pop("extends", None)
    if base is None:
        return raw, marks
    if not isinstance(base, str):
        raise _fault(source, marks, "expected the name of a scenario")
    if len(chain) >= MAX_EXTENDS:
        raise _fault(source, marks, f"a chain of more than {MAX_EXTENDS} files extending")
    if base in list_scenarios():
        base_raw, base_marks = read_raw(base)
    elif folder is not None and base.endswith(SCENARIO_SUFFIXES):
        if base in chain:
            raise _fault(source, marks, f"extends {base!r}, which leads back to it: a cycle")
        try:
            base_text = read_file(folder, base, SCENARIO_SUFFIXES, limit)
        except FolderError as err:
            raise _fault(source, marks, str(err)) from None
        base_raw, base_marks = _raw(base_text, base, folder, limit, (*chain, base))
    else:
        where = " or a file of the same folder" if folder is not None else ""
        raise _fault(source, marks, f"no scenario {base!r}: a shipped scenario's name{where}")
    del marks[("extends",)]
    return merge(base_raw, raw, base_marks, (), marks), base_marks


def spec_from_text(
    text: str, source: str = "<editor>", folder: Path | None = None, limit: int = 2**20
) -> ScenarioSpec:
    """The checked spec of scenario ``text`` (named ``source`` in problems); ``extends``
    may name a shipped scenario or a file of ``folder``. ``ScenarioError`` for any fault,
    each located; the layout checks that need a build run too."""
    try:
        raw, marks = _raw(text, source, folder, limit, (source,))
        spec = validate(raw, marks, fallback=source)
        spec.read_from(source, marks)
        return check_scenario(spec)
    except ScenarioError:
        raise
    except (ValueError, TypeError, RecursionError) as err:
        message = f"cannot be used: {type(err).__name__}: {err}"
        raise ScenarioError([Problem(source, None, (), message)]) from None


@dataclass(frozen=True)
class Summary:
    """What the gallery says of a scenario."""

    description: str
    n_agents: int
    gym_id: str | None

    @staticmethod
    def of(spec: ScenarioSpec, name: str | None) -> Summary:
        """``name``: a shipped scenario's (whose one-agent worlds have a Gymnasium id)."""
        gym = gym_id(name, spec.version) if name is not None and spec.n_agents == 1 else None
        return Summary(spec.description, spec.n_agents, gym)


def renderer_for(env: FlatlandParallelEnv) -> Renderer:
    """A renderer of ``env``'s world and every agent's senses (as ``play`` makes one)."""
    suite = env.running.sensors
    own = [[suite.cameras[k] for k in ks] for ks in suite.per_agent]
    return Renderer(env.spec, own)


def layout_picture(spec: ScenarioSpec, seed: int) -> np.ndarray:
    """The map of ``spec``'s world at reset with ``seed`` (no senses panel)."""
    env = FlatlandParallelEnv(spec)
    try:
        env.reset(seed=seed)
        renderer = renderer_for(env)
        frame = renderer.frame(env)
        x, y = renderer.map_origin
        width, height = renderer.map_size
        return frame[y : y + height, x : x + width]
    finally:
        env.close()


def encode(frame: np.ndarray, kind: str = "png", quality: int = 80) -> bytes:
    """A frame as PNG or JPEG bytes."""
    buffer = io.BytesIO()
    image = Image.fromarray(frame)
    if kind == "jpeg":
        image.save(buffer, format="JPEG", quality=quality)
    else:
        image.save(buffer, format="PNG", compress_level=3)
    return buffer.getvalue()
