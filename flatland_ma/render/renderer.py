"""Pictures of a world: a top-down view with every field of view, and beneath it a panel
of each agent's senses (``senses.py``): every sensor of every agent, labelled, its camera
strips as in the paper's figure (colour, then depth, then the kind of thing hit).

The panel is a grid of one block per agent (up to ``MAX_PANELS``), laid out once from the
agents' sensors, so every frame of an env has the same size (video files need that).
The renderer only reads the world and the readings last handed out; it never changes
them, and it draws no random numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pymunk
from PIL import Image, ImageDraw, ImageFont

from flatland_ma.render import senses
from flatland_ma.scenario.schema import ScenarioSpec
from flatland_ma.sensors.sensor import Sensor
from flatland_ma.sensors.textures import KINDS, shade

if TYPE_CHECKING:
    from flatland_ma.render.window import Window

ARENA_PIXELS = 480
"""Length in pixels of the arena's longer side in the picture."""
SUPERSAMPLE = 2
PANEL_MIN_WIDTH = 480
"""The frame is at least this wide, for the senses panel (a narrow arena is centred)."""
MAX_PANELS = 16
"""Agents with a block in the senses panel; more are counted in a note beneath."""
HEADER_HEIGHT = 14
"""The line naming an agent and its counters, atop its block."""
LABEL_HEIGHT = 12
"""The line naming a sensor, above its picture."""
GAP = 4
PAD = 4
BACKGROUND = (30, 30, 30)
LABEL_COLOR = (190, 190, 190)
FOCUS_COLOR = (255, 255, 255)
FOV_ALPHA = 60
DOT_RADIUS = 2.5
DOT_ALPHA = 200
"""Size and opacity of the dots where the rays of a sensor that sees all around (a lidar)
end: its area would cover the whole map."""
ZONE_ALPHA = 110
TEXTURE_STEP = 1.5
"""World units between the samples of a texture drawn along an outline."""


@dataclass(frozen=True)
class Placed:
    """Where one sensor's picture sits in the frame: its top-left corner and its slot."""

    x: int
    y: int
    slot: senses.Slot


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


def _sensor_label(sensor: Sensor) -> str:
    """A sensor's name, its kind when the name differs, and its reading's shape."""
    kind = getattr(sensor, "kind", "")
    name = sensor.name if sensor.name == kind or not kind else f"{sensor.name} ({kind})"
    shape = "x".join(str(n) for n in (sensor.space.shape or ()))
    return f"{name}  {shape}" if shape else name


def _rgb255(color) -> tuple[int, int, int]:
    r, g, b = (int(round(255 * c)) for c in color)
    return r, g, b


class Renderer:
    """Draws frames of one scenario's episodes; holds the human window if one is open.

    ``sensors[i]`` are agent i's sensors (the env's, the same every episode): the layout
    is planned from their spaces. ``blocks[i]`` is the top-left corner of agent i's
    block and ``placed[i][j]`` where its j-th sensor is drawn (agents past
    ``MAX_PANELS`` have none).
    """

    def __init__(self, spec: ScenarioSpec, sensors: list[list[Sensor]]):
        self.spec = spec
        width, height = spec.arena.size
        self.margin = spec.arena.wall.thickness
        self.scale = ARENA_PIXELS / max(width, height)
        self.map_size = (
            int(round((width + 2 * self.margin) * self.scale)),
            int(round((height + 2 * self.margin) * self.scale)),
        )
        frame_width = max(self.map_size[0], PANEL_MIN_WIDTH)
        self.map_origin = ((frame_width - self.map_size[0]) // 2, 0)
        shown = min(len(sensors), MAX_PANELS)
        self.hidden = len(sensors) - shown
        self.columns = max(1, math.ceil(math.sqrt(shown)))
        column = (frame_width - (self.columns - 1) * GAP) // self.columns
        slots = [[senses.plan(s, column - 2 * PAD) for s in own] for own in sensors[:shown]]
        heights = [sum(LABEL_HEIGHT + s.height + GAP for s in own) for own in slots]
        self.block_size = (column, HEADER_HEIGHT + max(heights, default=0) + GAP)
        top = self.map_size[1] + GAP
        self.blocks: list[tuple[int, int]] = []
        self.placed: list[list[Placed]] = []
        for i, own in enumerate(slots):
            x = (i % self.columns) * (column + GAP)
            y = top + (i // self.columns) * self.block_size[1]
            self.blocks.append((x, y))
            placed, y = [], y + HEADER_HEIGHT
            for slot in own:
                placed.append(Placed(x + PAD, y + LABEL_HEIGHT, slot))
                y += LABEL_HEIGHT + slot.height + GAP
            self.placed.append(placed)
        rows = math.ceil(shown / self.columns)
        note = LABEL_HEIGHT if self.hidden else 0
        self.size = (frame_width, top + rows * self.block_size[1] + note)
        self._font = ImageFont.load_default()
        self._window: Window | None = None
        # What never changes, drawn once: the background and every sensor's label.
        self._background = Image.new("RGB", self.size, BACKGROUND)
        draw = ImageDraw.Draw(self._background)
        for own, placed in zip(sensors, self.placed):
            for sensor, where in zip(own, placed):
                at = (where.x, where.y - LABEL_HEIGHT + 1)
                self._text(draw, at, _sensor_label(sensor), LABEL_COLOR, where.slot.width)
        if self.hidden:
            note = f"+{self.hidden} more agents (no panel)"
            self._text(draw, (PAD, self.size[1] - LABEL_HEIGHT), note, LABEL_COLOR, frame_width)

    def frame(self, env, focus: int | None = None) -> np.ndarray:
        """An RGB picture of the env's current state, uint8 of shape (H, W, 3); agent
        ``focus`` (an index), if given, is ringed on the map and its block framed."""
        episode = env.episode
        picture = self._background.copy()
        picture.paste(self._map(episode, focus), self.map_origin)
        draw = ImageDraw.Draw(picture)
        if len(env.possible_agents) > 1:
            self._number_agents(draw, episode)
        suite, task = episode.sensors, episode.task
        for i, (x, y) in enumerate(self.blocks):
            name = env.possible_agents[i]
            info = task.info(i)
            label = f"{name}  " + "  ".join(f"{k}: {_label(v)}" for k, v in info.items())
            if name not in env.agents:
                label += "  (done)"
            colour = _rgb255(episode.bodies[i].color)
            self._text(draw, (x + PAD, y + 1), label, colour, self.block_size[0] - PAD)
            for k, where in zip(suite.per_agent[i], self.placed[i]):
                image = senses.draw(suite.cameras[k], suite.readings[k], where.slot)
                picture.paste(Image.fromarray(image), (where.x, where.y))
            if i == focus:
                w, h = self.block_size
                draw.rectangle((x, y, x + w - 1, y + h - GAP), outline=FOCUS_COLOR)
        return np.asarray(picture, dtype=np.uint8).copy()

    def _text(self, draw, at, text: str, fill, width: int) -> None:
        """Text cut to fit ``width`` pixels (a long line never spills into a neighbour)."""
        while text and draw.textlength(text, font=self._font) > width:
            text = text[:-1]
        draw.text(at, text, fill=fill, font=self._font)

    def _number_agents(self, draw, episode) -> None:
        """Each agent's index beside it on the map, to match it with its block."""
        for i, body in enumerate(episode.bodies):
            if not body.visible:
                continue
            x, y = self._px(body.body.position, 1)
            r = body.shapes[0].radius * self.scale
            at = (self.map_origin[0] + x + r * 0.7, self.map_origin[1] + y - r * 0.7 - 10)
            draw.text(at, str(i), fill=(255, 255, 255), font=self._font)

    def _px(self, point, k: int) -> tuple[float, float]:
        """The pixel of a world point on the map drawn ``k`` times its size."""
        x, y = point
        height = self.spec.arena.size[1]
        return ((x + self.margin) * self.scale * k, (height - y + self.margin) * self.scale * k)

    def _map(self, episode, focus: int | None = None) -> Image.Image:
        """The arena from above: zones, then every field of view, then the entities, then
        each agent's heading (agent ``focus`` ringed); drawn ``SUPERSAMPLE`` times its
        size, then shrunk."""
        k = SUPERSAMPLE
        size = (self.map_size[0] * k, self.map_size[1] * k)
        image = Image.new("RGB", size, _rgb255(self.spec.arena.floor_color))
        draw = ImageDraw.Draw(image, "RGBA")

        def px(point) -> tuple[float, float]:
            return self._px(point, k)

        for zone in episode.world.zones:
            if zone.color is not None:
                x0, y0, x1, y1 = zone.rect
                corners = [px((x0, y1)), px((x1, y0))]
                draw.rectangle(corners, fill=(*_rgb255(zone.color), ZONE_ALPHA))
        self._draw_views(draw, px, episode)
        for entity in episode.world.entities:
            if entity.visible:
                self._draw_entity(draw, px, entity)
        for i, body in enumerate(episode.bodies):
            if body.visible:
                self._draw_heading(draw, px, body, ringed=i == focus)
        return image.reduce(k)  # the mean of each k x k square: smooth edges, cheaply

    def _draw_views(self, draw, px, episode) -> None:
        """What each visible agent's ray sensors see: a fan from the eye to where its rays
        end, or, for a sensor that sees all around (a lidar), a dot where each ends."""
        sensors, k = episode.sensors, SUPERSAMPLE
        for i, body in enumerate(episode.bodies):
            if not body.visible:
                continue
            for n in sensors.per_agent[i]:  # every sensor that casts rays
                sensor = sensors.cameras[n]
                if sensor.n_rays == 0:
                    continue
                eye = episode.eyes[n].body  # the base, or the head the sensor sits on
                ox, oy = eye.position
                heading = eye.angle
                dist = sensors.distance[sensors.slices[n]]
                points = [
                    px((ox + d * math.cos(heading + a), oy + d * math.sin(heading + a)))
                    for a, d in zip(sensor.angles, dist)
                ]
                if sensor.half_fov < math.pi - 1e-9:  # a fan from the eye
                    draw.polygon([px((ox, oy)), *points], fill=(*_rgb255(body.color), FOV_ALPHA))
                else:  # all around (a lidar): a dot where each ray ends
                    dot, colour = DOT_RADIUS * k, (*_rgb255(body.color), DOT_ALPHA)
                    for x, y in points:
                        draw.ellipse((x - dot, y - dot, x + dot, y + dot), fill=colour)

    def _draw_entity(self, draw, px, entity) -> None:
        """An entity's shapes, filled with its colour (or its texture's first colour) and
        outlined in black, a textured surface painted along the outline."""
        texture = entity.texture
        fill = _rgb255(entity.color if texture is None else texture.colors[0])
        textured = texture is not None and not texture.plain
        for shape in entity.shapes:
            body = entity.body if shape.body is None else shape.body
            if isinstance(shape, pymunk.Circle):
                cx, cy = px(body.local_to_world(shape.offset))
                r = shape.radius * self.scale * SUPERSAMPLE
                draw.ellipse((cx - r, cy - r, cx + r, cy + r), fill=fill, outline=(0, 0, 0))
                if textured:
                    centre = body.local_to_world(shape.offset)
                    self._draw_texture(draw, px, texture, _circle_outline(shape), centre)
            elif isinstance(shape, pymunk.Poly):
                pts = [body.local_to_world(v) for v in shape.get_vertices()]
                draw.polygon([px(p) for p in pts], fill=fill, outline=(0, 0, 0))
                if textured:
                    self._draw_texture(draw, px, texture, _polygon_outline(pts), None)

    def _draw_heading(self, draw, px, body, ringed: bool) -> None:
        """A line from an agent's centre to its rim, the way it faces; a ring round it if
        ``ringed``."""
        k = SUPERSAMPLE
        x, y = body.body.position
        a = body.body.angle
        r = body.shapes[0].radius
        draw.line(
            [px((x, y)), px((x + r * math.cos(a), y + r * math.sin(a)))],
            fill=(0, 0, 0),
            width=2 * k,
        )
        if ringed:
            cx, cy = px((x, y))
            ring = (r + 3) * self.scale * k
            box = (cx - ring, cy - ring, cx + ring, cy + ring)
            draw.ellipse(box, outline=FOCUS_COLOR, width=2 * k)

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
