"""GIFs of an episode's latest frames, made in the background with their progress.

A page asks for one (``POST /api/episodes/K/gif``) and gets a job at once; the frames it
had been sent are copied then, scaled down to ``limits.gif_width`` at most and further
so that all of them hold at most ``PIXEL_BUDGET`` pixels (a GIF of a few MB whatever the
length), given one palette and written with each frame shown as long as the page showed
it (the speed the viewer chose at the time, within [``MIN_FRAME_MS``, ``MAX_FRAME_MS``]).
The page polls the job (``GET /api/gifs/J``: frames done of the total) and downloads
the file when it is ready (``GET /api/gifs/J/file``). At most ``limits.gifs`` jobs are
kept: the oldest finished one is forgotten first; when every kept job is still running,
one more is refused.
"""

from __future__ import annotations

import asyncio
import collections
import io
import secrets
from dataclasses import dataclass, field

import anyio
import numpy as np
from PIL import Image

from flatland_ma.render.video import GIF_COLORS

MIN_FRAME_MS = 20
"""The shortest a GIF frame is shown (browsers slow down shorter ones)."""
MAX_FRAME_MS = 10_000
"""The longest (a frame of an episode watched at 0.001 frames a second is shown this long)."""
PALETTE_SAMPLES = 8
PIXEL_BUDGET = 24_000_000
"""Pixels of every frame of a GIF together: 205 frames of a four-agent world come out
about 300 pixels wide and 4 MB."""
MIN_WIDTH = 160


@dataclass
class GifJob:
    """One GIF being made: ``done`` of ``total`` frames; ``data`` once it is ready."""

    key: str
    total: int
    done: int = 0
    data: bytes | None = None
    error: str | None = None
    task: asyncio.Task | None = field(default=None, repr=False)

    @property
    def finished(self) -> bool:
        return self.data is not None or self.error is not None

    def progress(self) -> dict:
        return {
            "gif": self.key,
            "done": self.done,
            "total": self.total,
            "ready": self.data is not None,
            "bytes": len(self.data) if self.data is not None else None,
            "error": self.error,
        }


def frame_ms(fps: float) -> int:
    """How long a frame sent at ``fps`` frames a second is shown in the GIF."""
    return int(min(MAX_FRAME_MS, max(MIN_FRAME_MS, round(1000.0 / fps))))


def gif_size(width: int, height: int, frames: int, widest: int) -> tuple[int, int]:
    """The size a GIF's frames are scaled to: at most ``widest`` wide, all ``frames`` of
    them within ``PIXEL_BUDGET`` pixels (never below ``MIN_WIDTH``), the aspect kept."""
    budget = (PIXEL_BUDGET / max(1, frames) * width / height) ** 0.5
    scaled = max(MIN_WIDTH, min(widest, width, int(budget)))
    return scaled, max(1, round(height * scaled / width))


def _picture(data: bytes, size: tuple[int, int]) -> Image.Image:
    with Image.open(io.BytesIO(data)) as picture:
        image = picture.convert("RGB")
    if image.size != size:
        image = image.resize(size, Image.Resampling.BILINEAR, reducing_gap=2.0)
    return image


def encode_gif(frames: list[tuple[bytes, float]], width: int, job: GifJob | None = None) -> bytes:
    """A looping GIF of encoded pictures, each with the frame rate it was shown at,
    scaled by ``gif_size`` (at most ``width`` wide); ``job.done`` counts the frames done."""
    with Image.open(io.BytesIO(frames[0][0])) as first:
        size = gif_size(first.width, first.height, len(frames), width)
    step = max(1, len(frames) // PALETTE_SAMPLES)
    sample = [np.asarray(_picture(data, size)) for data, _ in frames[::step]]
    palette = Image.fromarray(np.concatenate(sample, axis=0)).quantize(
        GIF_COLORS, method=Image.Quantize.MEDIANCUT
    )
    quantized = []
    for data, _ in frames:
        image = _picture(data, size)
        quantized.append(image.quantize(palette=palette, dither=Image.Dither.NONE))
        if job is not None:
            job.done += 1
    out = io.BytesIO()
    quantized[0].save(
        out,
        format="GIF",
        save_all=True,
        append_images=quantized[1:],
        duration=[frame_ms(fps) for _, fps in frames],
        loop=0,
        optimize=True,
    )
    return out.getvalue()


class Gifs:
    """The GIF jobs of one studio."""

    def __init__(self, limit: int, width: int, limiter: anyio.CapacityLimiter):
        self.limit, self.width, self.limiter = limit, width, limiter
        self.jobs: collections.OrderedDict[str, GifJob] = collections.OrderedDict()

    def start(self, frames: list[tuple[bytes, float]]) -> GifJob | None:
        """A new job over ``frames`` (None when ``limit`` jobs are all still running)."""
        while len(self.jobs) >= self.limit:
            finished = next((k for k, j in self.jobs.items() if j.finished), None)
            if finished is None:
                return None
            del self.jobs[finished]
        job = GifJob(secrets.token_urlsafe(12), len(frames))
        self.jobs[job.key] = job
        job.task = asyncio.get_running_loop().create_task(self._make(job, frames))
        return job

    async def _make(self, job: GifJob, frames: list[tuple[bytes, float]]) -> None:
        try:
            job.data = await anyio.to_thread.run_sync(
                encode_gif, frames, self.width, job, limiter=self.limiter
            )
        except (OSError, ValueError) as err:  # a frame that does not decode, say
            job.error = f"the GIF could not be made ({type(err).__name__})"
        finally:
            job.task = None

    def get(self, key: str) -> GifJob | None:
        return self.jobs.get(key)
