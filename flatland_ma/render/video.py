"""Writing frames to a GIF or a PNG (Pillow), or to an MP4 (PyAV, from the ``render``
extra: its wheel carries FFmpeg's libraries); no display needed."""

from __future__ import annotations

import importlib.util
from fractions import Fraction
from pathlib import Path

import numpy as np
from PIL import Image

GIF_COLORS = 128
"""Size of the one palette shared by every frame (keeps files small)."""

SUFFIXES = (".gif", ".png", ".mp4")
"""The kinds of file these functions write."""

MP4_CODEC = "libx264"
"""H.264, which every player reads; it needs frames of even width and height."""


def check_writable(path: str | Path) -> None:
    """Raise ``ValueError`` (before anything is rendered) if ``path`` is no kind of file
    written here, or an MP4 without PyAV installed."""
    suffix = Path(path).suffix.lower()
    if suffix not in SUFFIXES:
        raise ValueError(
            f"cannot write {str(path)!r}: its suffix must be one of {', '.join(SUFFIXES)}"
        )
    if suffix == ".mp4" and importlib.util.find_spec("av") is None:
        raise ValueError(
            f"cannot write {str(path)!r}: MP4 needs PyAV (pip install av; or, in "
            "a clone of flatland_ma, its render extra: pip install -e '.[render]'); "
            "a .gif or .png needs nothing more"
        )


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


def save_mp4(frames: list[np.ndarray], path: str | Path, fps: float = 30.0) -> Path:
    """Write RGB frames (uint8, H x W x 3) as an H.264 MP4. An odd width or height gains
    one column or row, a copy of the last, since the codec needs even sizes."""
    import av  # the render extra

    if not frames:
        raise ValueError("no frames to write")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    height, width = frames[0].shape[:2]
    pad = ((0, height % 2), (0, width % 2), (0, 0))
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream(MP4_CODEC, rate=Fraction(fps).limit_denominator(1000))
        stream.width, stream.height = width + width % 2, height + height % 2
        stream.pix_fmt = "yuv420p"
        for frame in frames:
            image = av.VideoFrame.from_ndarray(np.pad(frame, pad, mode="edge"), format="rgb24")
            container.mux(stream.encode(image))
        container.mux(stream.encode())  # flush the frames the encoder still holds
    return path
