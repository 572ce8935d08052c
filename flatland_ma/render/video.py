"""Writing frames to a GIF or a PNG (Pillow; no display needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

GIF_COLORS = 128
"""Size of the one palette shared by every frame (keeps files small)."""


def save_gif(frames: list[np.ndarray], path: str | Path, fps: float = 30.0) -> Path:
    """Write RGB frames (uint8, H x W x 3) as a looping GIF."""
    if not frames:
        raise ValueError("no frames to write")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    palette = Image.fromarray(np.concatenate(frames[:: max(1, len(frames) // 8)], axis=0))
    palette = palette.quantize(GIF_COLORS, method=Image.Quantize.MEDIANCUT)
    images = [
        Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in frames
    ]
    images[0].save(
        path,
        save_all=True,
        append_images=images[1:],
        duration=max(20, int(round(1000 / fps))),
        loop=0,
        optimize=True,
    )
    return path


def save_png(frame: np.ndarray, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(frame).save(path)
    return path
