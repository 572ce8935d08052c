"""Pictures of a world: a top-down view with each agent's field of view, and each agent's
1-D image drawn as strips beneath it (colour, then depth), as in the paper's figure.

The renderer only reads the world and the sensors; it never changes them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pymunk
from PIL import Image, ImageDraw, ImageFont

from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.textures import KINDS, shade

if TYPE_CHECKING:
    from flatland_ma.render.window import Window

ARENA_PIXELS = 480
"""Length in pixels of the arena's longer side in the picture."""
SUPERSAMPLE = 2
STRIP_HEIGHT = 18
LABEL_HEIGHT = 14
FOV_ALPHA = 60
ZONE_ALPHA = 110
TEXTURE_STEP = 1.5
"""World units between the samples of a texture drawn along an outline."""


def _label(value) -> str:
    if isinstance(value, tuple):
        return ",".join(value) or "-"
    return f"{value:g}"


def _polygon_outline(pts) -> list:
    """Short pieces along a polygon's perimeter, each with its distance u from the start."""
    pieces, u = [], 0.0
    for i in range(len(pts)):
        a, b = pts[i], pts[(i + 1) % len(pts)]
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        n = max(1, int(length / TEXTURE_STEP))
        for k in range(n):
            p = (a[0] + (b[0] - a[0]) * k / n, a[1] + (b[1] - a[1]) * k / n)
            q = (a[0] + (b[0] - a[0]) * (k + 1) / n, a[1] + (b[1] - a[1]) * (k + 1) / n)
            pieces.append(((p, q), u + length * (k + 0.5) / n))
        u += length
    return pieces


def _circle_outline(shape: pymunk.Circle) -> list:
    body, r = shape.body, shape.radius
    assert body is not None, "a shape on no body"
    cx, cy = body.local_to_world(shape.offset)
    n = max(8, int(2 * math.pi * r / TEXTURE_STEP))
    pieces = []
    for k in range(n):
        a0, a1 = 2 * math.pi * k / n, 2 * math.pi * (k + 1) / n
        p = (cx + r * math.cos(body.angle + a0), cy + r * math.sin(body.angle + a0))
        q = (cx + r * math.cos(body.angle + a1), cy + r * math.sin(body.angle + a1))
        pieces.append(((p, q), r * (a0 + a1) / 2))
    return pieces


def _rgb255(color) -> tuple[int, int, int]:
    r, g, b = (int(round(255 * c)) for c in color)
    return r, g, b


class Renderer:
    """Draws frames of one scenario's episodes; holds the human window if one is open."""

    def __init__(self, spec: ScenarioSpec):
        self.spec = spec
        width, height = spec.arena.size
        self.margin = spec.arena.wall.thickness
        self.scale = ARENA_PIXELS / max(width, height)
        self.map_size = (
            int(round((width + 2 * self.margin) * self.scale)),
            int(round((height + 2 * self.margin) * self.scale)),
        )
        self.strip_block = LABEL_HEIGHT + 2 * STRIP_HEIGHT + 4
        self.size = (self.map_size[0], self.map_size[1] + spec.n_agents * self.strip_block)
        self._font = ImageFont.load_default()
        self._window: Window | None = None

    def frame(self, env) -> np.ndarray:
        """An RGB picture of the env's current state, uint8 of shape (H, W, 3)."""
        episode = env.episode
        picture = Image.new("RGB", self.size, (30, 30, 30))
        picture.paste(self._map(episode), (0, 0))
        draw = ImageDraw.Draw(picture)
        sensors, task = episode.sensors, episode.task
        for i, name in enumerate(env.possible_agents):
            top = self.map_size[1] + i * self.strip_block
            info = task.info(i)
            label = f"{name}  " + "  ".join(f"{k}: {_label(v)}" for k, v in info.items())
            draw.text((4, top + 1), label, fill=_rgb255(episode.bodies[i].color), font=self._font)
            image = sensors.image[sensors.slices[sensors.per_agent[i][0]]]  # its first sensor
            colour = (np.clip(image[:, :3], 0, 1) * 255).astype(np.uint8)[None]
            depth = ((1.0 - np.clip(image[:, 3], 0, 1)) * 255).astype(np.uint8)
            depth = np.repeat(depth[None, :, None], 3, axis=2)
            y = top + LABEL_HEIGHT
            for row in (colour, depth):
                strip = Image.fromarray(row, "RGB").resize(
                    (self.size[0], STRIP_HEIGHT), Image.Resampling.NEAREST
                )
                picture.paste(strip, (0, y))
                y += STRIP_HEIGHT + 2
        return np.asarray(picture, dtype=np.uint8).copy()

    def _map(self, episode) -> Image.Image:
        k = SUPERSAMPLE
        size = (self.map_size[0] * k, self.map_size[1] * k)
        image = Image.new("RGB", size, _rgb255(self.spec.arena.floor_color))
        draw = ImageDraw.Draw(image, "RGBA")

        def px(point) -> tuple[float, float]:
            x, y = point
            height = self.spec.arena.size[1]
            return ((x + self.margin) * self.scale * k, (height - y + self.margin) * self.scale * k)

        for zone in episode.world.zones:
            if zone.color is not None:
                x0, y0, x1, y1 = zone.rect
                corners = [px((x0, y1)), px((x1, y0))]
                draw.rectangle(corners, fill=(*_rgb255(zone.color), ZONE_ALPHA))

        sensors = episode.sensors
        for i, body in enumerate(episode.bodies):
            if not body.visible:
                continue
            first = sensors.per_agent[i][0]  # its first sensor
            eye = episode.eyes[first].body  # the base, or the head the sensor sits on
            ox, oy = eye.position
            heading = eye.angle
            cam = sensors.cameras[first]
            dist = sensors.distance[sensors.slices[first]]
            points = [px((ox, oy))]
            for angle, d in zip(cam.angles, dist):
                points.append(
                    px((ox + d * math.cos(heading + angle), oy + d * math.sin(heading + angle)))
                )
            draw.polygon(points, fill=(*_rgb255(body.color), FOV_ALPHA))

        for entity in episode.world.entities:
            if not entity.visible:
                continue
            texture = entity.texture
            fill = _rgb255(entity.color if texture is None else texture.colors[0])
            for shape in entity.shapes:
                body = entity.body if shape.body is None else shape.body
                if isinstance(shape, pymunk.Circle):
                    cx, cy = px(body.local_to_world(shape.offset))
                    r = shape.radius * self.scale * k
                    draw.ellipse((cx - r, cy - r, cx + r, cy + r), fill=fill, outline=(0, 0, 0))
                    outline = _circle_outline(shape)
                    centre = body.local_to_world(shape.offset)
                elif isinstance(shape, pymunk.Poly):
                    pts = [body.local_to_world(v) for v in shape.get_vertices()]
                    draw.polygon([px(p) for p in pts], fill=fill, outline=(0, 0, 0))
                    outline = _polygon_outline(pts)
                    centre = None
                else:  # pragma: no cover - the builder makes only circles and polygons
                    continue
                if texture is not None and not texture.plain:
                    self._draw_texture(draw, px, texture, outline, centre)

        for body in episode.bodies:
            if not body.visible:
                continue
            x, y = body.body.position
            a = body.body.angle
            r = body.shapes[0].radius
            draw.line(
                [px((x, y)), px((x + r * math.cos(a), y + r * math.sin(a)))],
                fill=(0, 0, 0),
                width=2 * k,
            )
        return image.resize(self.map_size, Image.Resampling.LANCZOS)

    def _draw_texture(self, draw, px, texture, outline, centre) -> None:
        """Paint the surface as rays see it: its texture along the outline (as thin bands
        along a polygon's edges, as wedges of a circle)."""
        kind = KINDS[texture.kind]
        a, b = np.array(texture.colors[0]), np.array(texture.colors[1])
        width = max(2, int(round(1.5 * SUPERSAMPLE * self.scale)))
        for (p, q), u in outline:
            mid = ((p[0] + q[0]) / 2, (p[1] + q[1]) / 2)
            w = shade(kind, texture.period, texture.duty, texture.seed, u, mid[0], mid[1])
            colour = tuple(int(round(255 * c)) for c in a * (1 - w) + b * w)
            if centre is None:
                draw.line([px(p), px(q)], fill=colour, width=width)
            else:
                draw.polygon([px(centre), px(p), px(q)], fill=colour)

    @property
    def closed_by_user(self) -> bool:
        """Whether the human window was closed by its user."""
        return self._window is not None and self._window.closed_by_user

    def show(self, frame: np.ndarray, fps: int) -> None:
        """Show a frame in the human window (opened on first use)."""
        if self._window is None:
            from flatland_ma.render.window import Window

            self._window = Window(self.size, "flatland_ma")
        self._window.show(frame, fps)

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window: Window | None = None
