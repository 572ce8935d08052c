"""Pictures of what each agent senses: one small view per sensor, drawn from its reading.

A sensor may draw itself (``Sensor.picture``: the camera does, as the paper's strips);
every other reading is drawn from its shape alone, so a new kind of sensor shows up here
without any change:

- a vector of up to ``MAX_BARS`` entries: a row of bars, from zero when its range spans
  zero (e.g. proprioception's -1..1), else from its low end;
- a longer vector: a heat strip, one cell per entry (e.g. a lidar's ring of distances);
- ``rays x channels`` (up to ``MAX_STRIPS`` channels): one heat strip per channel;
- a wider 2-D array, or ``H x W x C``: a small image, in colour when C is 3, else the
  first channel in grey.

Values are placed in the space's low..high (the reading's own range where a bound is
infinite). Each sensor gets a fixed slot, planned once from its space, so frames keep one
size for the whole episode.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from PIL import Image

from flatland_ma.sensors.sensor import Sensor

STRIP_HEIGHT = 12
"""Height in pixels of one strip (one row of a picture drawn as strips)."""
STRIP_GAP = 2
BAR_HEIGHT = 28
IMAGE_HEIGHT = 96
"""Tallest an image-like reading is drawn."""
MAX_BARS = 16
"""Vectors up to this long are drawn as bars, longer ones as a heat strip."""
MAX_STRIPS = 8
"""Pictures (and 2-D readings) with up to this many rows are drawn as strips."""
BAR_COLOR = np.array((225, 225, 225), np.uint8)
BAR_BACK = np.array((55, 55, 55), np.uint8)
HEAT = np.array(
    [(20, 20, 60), (40, 90, 160), (40, 170, 140), (170, 210, 60), (250, 240, 120)], np.float64
)
"""A dark-to-bright colour ramp for heat strips: low is dark blue, high pale yellow."""


@dataclass(frozen=True)
class Slot:
    """How one sensor is drawn: ``style`` (``strips``, ``bars`` or ``image``) and the
    size of its picture in pixels."""

    style: str
    width: int
    height: int


def sample(space: spaces.Space) -> np.ndarray:
    """A reading that lies in ``space`` (zeros pushed into its bounds), for planning."""
    shape = space.shape or ()
    zeros = np.zeros(shape, np.float64)
    if isinstance(space, spaces.Box):
        return np.clip(zeros, space.low, space.high)
    return zeros


def plan(sensor: Sensor, width: int) -> Slot:
    """The slot of ``sensor`` in a panel column ``width`` pixels wide."""
    reading = sample(sensor.space)
    own = sensor.picture(reading)
    if own is not None:
        rows, cols = own.shape[:2]
        if rows <= MAX_STRIPS:
            return Slot("strips", width, rows * (STRIP_HEIGHT + STRIP_GAP) - STRIP_GAP)
        return _image_slot(rows, cols, width)
    shape = _shape(reading)
    if len(shape) == 1:
        if shape[0] <= MAX_BARS:
            return Slot("bars", width, BAR_HEIGHT)
        return Slot("strips", width, STRIP_HEIGHT)
    if len(shape) == 2 and shape[1] <= MAX_STRIPS:
        return Slot("strips", width, shape[1] * (STRIP_HEIGHT + STRIP_GAP) - STRIP_GAP)
    return _image_slot(shape[0], shape[1], width)


def draw(sensor: Sensor, reading: np.ndarray | None, slot: Slot) -> np.ndarray:
    """The picture of one reading, uint8 of exactly the slot's size (a blank one for no
    reading)."""
    if reading is None:
        return np.broadcast_to(BAR_BACK, (slot.height, slot.width, 3)).copy()
    own = sensor.picture(reading)
    if own is None:
        own = _generic(reading, sensor.space, slot)
    if slot.style == "strips":
        return _strips(own, slot)
    return _fit(own, slot.width, slot.height)


def _image_slot(rows: int, cols: int, width: int) -> Slot:
    """The largest slot of the image's proportions at most ``width`` wide and
    ``IMAGE_HEIGHT`` tall."""
    rows, cols = max(rows, 1), max(cols, 1)
    height = max(1, min(IMAGE_HEIGHT, round(width * rows / cols)))
    return Slot("image", max(1, min(width, round(height * cols / rows))), height)


def _shape(reading: np.ndarray) -> tuple[int, ...]:
    """The shape the reading is drawn by: vectors and images as they are; anything else
    (a scalar, four or more axes) flattened to a vector."""
    shape = reading.shape
    if 1 <= len(shape) <= 3:
        return shape
    return (int(np.prod(shape)),)


def _unit(reading: np.ndarray, space: spaces.Space) -> np.ndarray:
    """The reading placed in 0..1 over its space's bounds (its own range where a bound is
    missing or infinite)."""
    x = np.asarray(reading, np.float64)
    lo = np.full(x.shape, np.nanmin(x) if x.size else 0.0)
    hi = np.full(x.shape, np.nanmax(x) if x.size else 1.0)
    if isinstance(space, spaces.Box) and space.low.size == x.size:
        low, high = space.low.reshape(x.shape), space.high.reshape(x.shape)
        finite = np.isfinite(low) & np.isfinite(high)
        lo, hi = np.where(finite, low, lo), np.where(finite, high, hi)
    span = np.where(hi > lo, hi - lo, 1.0)
    return np.clip(np.nan_to_num((x - lo) / span), 0.0, 1.0)


def heat(values: np.ndarray) -> np.ndarray:
    """Values in 0..1 as colours of the heat ramp, uint8 with one more axis of 3."""
    position = np.clip(values, 0.0, 1.0) * (len(HEAT) - 1)
    below = np.minimum(position.astype(np.intp), len(HEAT) - 2)
    t = (position - below)[..., None]
    return np.rint(HEAT[below] * (1 - t) + HEAT[below + 1] * t).astype(np.uint8)


def _generic(reading: np.ndarray, space: spaces.Space, slot: Slot) -> np.ndarray:
    shape = _shape(reading)
    flat = np.asarray(reading).reshape(shape)
    if slot.style == "bars":
        return _bars(flat, space, slot)
    unit = _unit(reading, space).reshape(shape)
    if slot.style == "strips":
        rows = unit[None] if unit.ndim == 1 else unit.T  # one row per channel
        return heat(rows)
    if len(shape) == 3 and shape[-1] == 3:
        return np.rint(unit * 255).astype(np.uint8)
    grey = unit if unit.ndim == 2 else unit[..., 0]
    return np.repeat(np.rint(grey * 255).astype(np.uint8)[..., None], 3, axis=2)


def _bars(values: np.ndarray, space: spaces.Space, slot: Slot) -> np.ndarray:
    """One bar per entry, filling the slot: up from the zero line (or the bottom)."""
    unit = _unit(values, space)
    zero = _unit(np.zeros_like(values, np.float64), space)  # where 0 sits in each range
    n, (h, w) = len(values), (slot.height, slot.width)
    picture = np.broadcast_to(BAR_BACK, (h, w, 3)).copy()
    edges = np.linspace(0, w, n + 1).round().astype(int)
    for i in range(n):
        top, base = (1 - unit[i]) * (h - 1), (1 - zero[i]) * (h - 1)
        a, b = sorted((int(round(top)), int(round(base))))
        left, right = edges[i] + 1, max(edges[i] + 2, edges[i + 1] - 1)
        picture[a : b + 1, left:right] = BAR_COLOR
    return picture


def _strips(picture: np.ndarray, slot: Slot) -> np.ndarray:
    """Each row of the picture stretched into a strip the slot's width, with gaps."""
    out = np.zeros((slot.height, slot.width, 3), np.uint8)
    rows = picture.shape[0]
    for r in range(rows):
        top = r * (STRIP_HEIGHT + STRIP_GAP)
        if top >= slot.height:
            break
        strip = _fit(picture[r : r + 1], slot.width, STRIP_HEIGHT)
        out[top : top + STRIP_HEIGHT] = strip[: slot.height - top]
    return out


def _fit(picture: np.ndarray, width: int, height: int) -> np.ndarray:
    """The picture scaled to exactly ``width x height`` (nearest pixel: cells stay sharp)."""
    if picture.shape[:2] == (height, width):
        return np.ascontiguousarray(picture, np.uint8)
    image = Image.fromarray(np.ascontiguousarray(picture, np.uint8))
    return np.asarray(image.resize((width, height), Image.Resampling.NEAREST))
