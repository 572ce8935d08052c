"""The top-down sensor: a small map of the square around the agent, turned with it (or
held north up)."""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable

import numpy as np
import pymunk
from gymnasium import spaces

from flatland_ma.sensors import topdown_kernel
from flatland_ma.sensors.geometry import Geometry
from flatland_ma.sensors.semantic import SEMANTIC_KINDS
from flatland_ma.sensors.sensor import Sensor
from flatland_ma.sensors.sensor_suite import compiled_kernel
from flatland_ma.sensors.topdown_kernel import Outline, View

CHANNELS = ("rgb", "semantic", "visibility")

_OUTLINES: weakref.WeakKeyDictionary[Geometry, Outline] = weakref.WeakKeyDictionary()
"""The outline of each episode's geometry, shared by all its top-down sensors."""


class Topdown(Sensor, kind="topdown"):
    """An egocentric map: ``size`` x ``size`` pixels covering ``extent`` x ``extent``
    world units around the mount, turned so that the heading points up.

    Row 0 is the farthest ahead and column 0 the farthest to the agent's left: the image
    is the world as a map held with the heading up. Its centre lies ``ahead * extent``
    units ahead of the mount's centre (0: the agent in the middle; 0.5: on the bottom
    edge). A pixel shows what covers its centre: walls, doors, obstacles, items and agents
    (other agents and the agent itself, with its head and arms) as filled shapes; where
    shapes overlap, the one added to the world last (agents over items over obstacles
    over walls). Bare floor, and zones, which the cameras do not see either, are nothing.

    Per pixel, the ``channels`` in order: ``rgb``, the colour the cameras see, without
    falloff, a textured surface showing its first colour (black for nothing);
    ``semantic``, the kind (``SEMANTIC_KINDS``) as its id or one-hot; ``visibility``, 1
    where the agent sees the pixel. A pixel is seen when its centre lies within ``fov``
    of the heading and no wall, door, obstacle or other agent stands on the line of sight
    from the mount's centre to it, but the one the centre lies in: the agent sees the
    whole of a wall or an obstacle it faces, and nothing behind it (items hide nothing;
    nor does the agent's own body). With ``masked``, pixels not seen are 0 in every
    channel but visibility: add ``visibility``, or use a one-hot ``semantic``, to tell
    them from bare floor.

    With ``turned`` False the map is held north up whichever way the agent faces (row 0
    the farthest north, column 0 the farthest west), and ``ahead`` and ``fov`` count from
    north instead of the heading.

    The observation is ``Box(0, high, (size, size, width), float32)``: channels last, rgb
    and visibility in [0, 1], the semantic id in [0, 5]. The default (``rgb``) gives width 3.
    """

    def __init__(
        self,
        size: int = 32,
        extent: float = 160.0,
        ahead: float = 0.0,
        channels: tuple[str, ...] = ("rgb",),
        semantic: str = "id",
        masked: bool = False,
        fov: float = 360.0,
        mount: str = "base",
        turned: bool = True,
        name: str = "topdown",
    ):
        if unknown := set(channels) - set(CHANNELS):
            raise ValueError(f"unknown top-down channels {sorted(unknown)}")
        self.name, self.mount = name, mount
        self.size, self.extent, self.ahead = size, float(extent), float(ahead)
        self.channels, self.onehot, self.masked = tuple(channels), semantic == "onehot", masked
        self.fov, self.turned = float(fov), bool(turned)
        kinds = len(SEMANTIC_KINDS)
        high = {
            "rgb": [1.0] * 3,
            "semantic": [1.0] * kinds if self.onehot else [kinds - 1.0],
            "visibility": [1.0],
        }
        top = np.array([h for c in self.channels for h in high[c]], np.float32)
        self._widths = {c: len(h) for c, h in high.items()}
        self._shape = shape = (size, size, len(top))
        self.space = spaces.Box(np.zeros(shape, np.float32), np.broadcast_to(top, shape).copy())
        self._pixels = _pixel_layout(size, self.extent, self.ahead, math.radians(self.fov))
        self._draw: Callable | None = None
        self._args: tuple = ()
        self._image = np.zeros(shape, np.float32)

    def attach(self, suite, k: int) -> None:
        geo = suite.geometry
        outline = _OUTLINES.get(geo)
        if outline is None:
            outline = _OUTLINES[geo] = _outline(geo, suite.kinds)
        carrier = suite.carriers[k]
        visibility = -1  # the visibility channel's column, if it has one
        if "visibility" in self.channels:
            before = self.channels[: self.channels.index("visibility")]
            visibility = sum(self._widths[c] for c in before)
        n_pixels = self.size * self.size
        pixel, order, angle, in_fov, reach = self._pixels
        view = View(
            frame=np.array([self.extent / self.size, self.ahead * self.extent, reach, self.size]),
            flags=np.array(
                [
                    geo.body_row[carrier.index],
                    carrier.owner,
                    self.masked or visibility >= 0,
                    self.masked,
                    visibility,
                    0,
                    self.turned,
                ],
                np.int64,
            ),
            pixel=pixel,
            order=order,
            angle=angle,
            in_fov=in_fov,
            values=self._values(geo, suite.kinds),
            poly_stamp=np.zeros(len(outline.poly_first) - 1, np.int64),
            circ_stamp=np.zeros(max(len(geo.shapes.circ_local), 1), np.int64),
            ids=np.full(n_pixels, -1, np.int32),
            seen=np.ones(n_pixels, np.bool_),
            out=np.zeros((n_pixels, self._shape[2]), np.float32),
        )
        self._args = (geo.pose, geo.shapes, geo.grid, geo.looks, outline, view)
        self._draw = compiled_kernel(self._args, topdown_kernel.draw)
        self._image = view.out.reshape(self._shape)  # the same memory, as an image

    def _values(self, geo: Geometry, kinds: np.ndarray) -> np.ndarray:
        """Each entity's channel values, and bare floor's in the last row."""
        colours = np.clip(geo.looks.colors[:, :3], 0.0, 1.0)
        rgb = np.concatenate([colours, np.zeros((1, 3), np.float32)])
        kind = kinds.astype(np.int64)
        semantic = np.eye(len(SEMANTIC_KINDS))[kind] if self.onehot else kind[:, None]
        columns = {"rgb": rgb, "semantic": semantic, "visibility": np.ones((len(kind), 1))}
        return np.concatenate([columns[c] for c in self.channels], axis=1).astype(np.float32)

    def read(self, results, k: int) -> np.ndarray:
        assert self._draw is not None, "a top-down sensor read before it was attached"
        self._draw(*self._args)
        return self._image.copy()


def _pixel_layout(size: int, extent: float, ahead: float, fov: float) -> tuple:
    """Where the pixels lie from the mount, which never changes: their centres, their order
    by angle, the sorted angles, whether each is in the field of view, and the farthest
    centre's distance."""
    side = extent / size
    steps = (size / 2 - np.arange(size) - 0.5) * side
    forward, left = np.meshgrid(ahead * extent + steps, steps, indexing="ij")
    pixel = np.stack([forward.ravel(), left.ravel()], axis=1)
    distance = np.hypot(pixel[:, 0], pixel[:, 1])
    angle = np.arctan2(pixel[:, 1], pixel[:, 0])
    angle = np.where(angle <= -math.pi, angle + 2 * math.pi, angle)
    order = np.argsort(angle, kind="stable").astype(np.int32)
    in_fov = np.abs(angle) <= fov / 2 + 1e-12
    return pixel, order, angle[order].copy(), in_fov, float(distance.max())


def _outline(geo: Geometry, kinds: np.ndarray) -> Outline:
    """Which segments make which polygon, and what hides what.

    The geometry packs each convex polygon's edges one after the other, entity after
    entity and shape after shape; counting the corners of each polygon shape in the same
    order gives where each polygon starts.
    """
    corners = [
        len(shape.get_vertices())
        for entity in geo.entities
        for shape in entity.shapes
        if isinstance(shape, pymunk.Poly)
    ]
    first = np.zeros(len(corners) + 1, np.int32)
    first[1:] = np.cumsum(corners)
    shapes = geo.shapes
    if first[-1] != len(shapes.seg_local) or np.any(shapes.seg_u0[first[:-1]] != 0.0):
        raise RuntimeError("the polygons do not match the packed geometry")
    seg_poly = np.repeat(np.arange(len(corners), dtype=np.int32), corners)
    fixed = np.array([e.fixed for e in geo.entities], np.bool_)
    starts = shapes.seg_entity[first[:-1]] if len(corners) else np.zeros(0, np.int32)
    loose_poly = np.flatnonzero(~fixed[starts]).astype(np.int32)
    blocks = kinds[:-1] != SEMANTIC_KINDS.index("item")
    return Outline(first, seg_poly, loose_poly, blocks)
