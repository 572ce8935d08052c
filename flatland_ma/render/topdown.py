"""Pictures of a world: a top-down view with each agent's field of view, and each agent's
1-D image drawn as strips beneath it (colour, then depth), as in the paper's figure.

The renderer only reads the world and the sensors; it never changes them.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk
from PIL import Image, ImageDraw, ImageFont

from flatland_ma.scenario.schema import ScenarioSpec

ARENA_PIXELS = 480
"""Length in pixels of the arena's longer side in the picture."""
SUPERSAMPLE = 2
STRIP_HEIGHT = 18
LABEL_HEIGHT = 14
FOV_ALPHA = 60


def _rgb255(color) -> tuple[int, int, int]:
    return tuple(int(round(255 * c)) for c in color)


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
        self._window = None

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
            label = f"{name}  " + "  ".join(f"{k}: {v:g}" for k, v in info.items())
            draw.text((4, top + 1), label, fill=_rgb255(episode.bodies[i].color), font=self._font)
            image = sensors.image[sensors.slices[i]]
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

        sensors = episode.sensors
        for i, body in enumerate(episode.bodies):
            ox, oy = body.body.position
            heading = body.body.angle
            cam = sensors.cameras[i]
            dist = sensors.distance[sensors.slices[i]]
            points = [px((ox, oy))]
            for angle, d in zip(cam.angles, dist):
                points.append(
                    px((ox + d * math.cos(heading + angle), oy + d * math.sin(heading + angle)))
                )
            draw.polygon(points, fill=(*_rgb255(body.color), FOV_ALPHA))

        for entity in episode.world.entities:
            if not entity.visible:
                continue
            fill = _rgb255(entity.color)
            for shape in entity.shapes:
                body = shape.body
                if isinstance(shape, pymunk.Circle):
                    cx, cy = px(body.local_to_world(shape.offset))
                    r = shape.radius * self.scale * k
                    draw.ellipse((cx - r, cy - r, cx + r, cy + r), fill=fill, outline=(0, 0, 0))
                elif isinstance(shape, pymunk.Poly):
                    pts = [px(body.local_to_world(v)) for v in shape.get_vertices()]
                    draw.polygon(pts, fill=fill, outline=(0, 0, 0))

        for body in episode.bodies:
            x, y = body.body.position
            a = body.body.angle
            r = body.shapes[0].radius
            draw.line(
                [px((x, y)), px((x + r * math.cos(a), y + r * math.sin(a)))],
                fill=(0, 0, 0),
                width=2 * k,
            )
        return image.resize(self.map_size, Image.Resampling.LANCZOS)

    def show(self, frame: np.ndarray, fps: int) -> None:
        """Show a frame in the human window (opened on first use)."""
        if self._window is None:
            from flatland_ma.render.window import Window

            self._window = Window(self.size, "flatland_ma")
        self._window.show(frame, fps)

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None
