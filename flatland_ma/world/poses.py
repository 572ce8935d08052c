"""The physics bridge's batch tier (``physics.py``): the poses of a space's moving bodies
read in one call of ``pymunk.batch`` (public, though pymunk calls it experimental), or
through pymunk's attributes where a world has few of them. Nothing here reaches past
pymunk's documented API."""

from __future__ import annotations

from typing import Any

import numpy as np
import pymunk

_batch: Any
try:
    from pymunk import batch as _batch
except ImportError:  # a pymunk before 7: no batch tier
    _batch = None

BATCH_FROM = 5
"""Moving bodies from which a world's poses are cheaper through ``pymunk.batch`` than
through attributes: it reads every body of the space, fixed items too, for about 12 µs
and more (measured per read on pymunk 7.3.1, attributes against batch: 1 body 4.3 and
12.9 µs, 4 bodies 10.1 and 16.4, 5 bodies 29.5 and 22.0, 8 bodies 34.3 and 19.6)."""


def batch_found() -> bool:
    """Whether ``pymunk.batch`` reads ids, positions and angles as this module expects."""
    try:
        space, body = pymunk.Space(), pymunk.Body(1.0, 1.0)
        body.position, body.angle = (1.5, -2.0), 0.25
        space.add(body)
        return _space_poses(space, _batch.Buffer()) == ([body.id], [(1.5, -2.0, 0.25)])
    except (AttributeError, TypeError, ValueError):
        return False


def _pose_fields() -> Any:
    fields = _batch.BodyFields
    return fields.BODY_ID | fields.POSITION | fields.ANGLE


def _space_poses(space: pymunk.Space, buffer: Any) -> tuple[list, list]:
    buffer.clear()
    _batch.get_space_bodies(space, _pose_fields(), buffer)
    ids = np.frombuffer(buffer.int_buf(), np.uintp).tolist()
    values = np.frombuffer(buffer.float_buf(), np.float64).reshape(-1, 3)
    return ids, [tuple(row) for row in values.tolist()]


class SpacePoses:
    """The poses of some bodies of one space, read in one ``pymunk.batch`` call: ``read``
    writes each body's (x, y, angle) into its row of ``pose``; a body taken out of the
    space (an agent retired in the step) is read through its attributes. Where each body
    lies in what pymunk hands back is worked out again only when the space's bodies
    changed."""

    def __init__(self, pose: np.ndarray, bodies: list[pymunk.Body]):
        self.pose = pose
        self._bodies = list(bodies)  # their structs live while they are referenced here
        self._in = next((b.space for b in bodies if b.space is not None), None)
        """The space the bodies are in (None: none is)."""
        self._ids = np.array([b.id for b in bodies], np.uintp)
        self._buffer = _batch.Buffer()
        self._fields = _pose_fields()
        self._seen = b""
        """The ids pymunk handed back last, as bytes."""
        self._found, self._rows = np.zeros(0, np.intp), np.zeros(0, np.intp)
        self._missing: list[int] = list(range(len(bodies)))

    def read(self) -> None:
        if self._in is not None:
            buffer = self._buffer
            buffer.clear()
            _batch.get_space_bodies(self._in, self._fields, buffer)
            ids = bytes(buffer.int_buf())
            if ids != self._seen:
                self._locate(np.frombuffer(ids, np.uintp))
                self._seen = ids
            values = np.frombuffer(buffer.float_buf(), np.float64).reshape(-1, 3)
            self.pose[self._found] = values[self._rows]
        for i in self._missing:
            body = self._bodies[i]
            self.pose[i] = (*body.position, body.angle)

    def _locate(self, ids: np.ndarray) -> None:
        """Which of our bodies are among ``ids`` (``_found``), at which rows (``_rows``)."""
        where = {body_id: row for row, body_id in enumerate(ids.tolist())}
        rows = [where.get(body_id, -1) for body_id in self._ids.tolist()]
        self._found = np.array([i for i, r in enumerate(rows) if r >= 0], np.intp)
        self._rows = np.array([r for r in rows if r >= 0], np.intp)
        self._missing = [i for i, r in enumerate(rows) if r < 0]


class AttributePoses:
    """``SpacePoses`` through pymunk's attributes: cheaper for a few bodies."""

    def __init__(self, pose: np.ndarray, bodies: list[pymunk.Body]):
        self.pose = pose
        self._bodies = list(bodies)

    def read(self) -> None:
        if self._bodies:
            self.pose[:] = [(*body.position, body.angle) for body in self._bodies]


def poses_of(pose: np.ndarray, bodies: list[pymunk.Body]) -> SpacePoses | AttributePoses:
    """The batch tier's reader of these bodies' poses, the cheaper for their number."""
    return SpacePoses(pose, bodies) if len(bodies) >= BATCH_FROM else AttributePoses(pose, bodies)
