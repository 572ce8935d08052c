"""TensorBoard scalars beside a run's CSV log (``tensorboard --logdir runs``)."""

from __future__ import annotations

from pathlib import Path


class Scalars:
    """Writes scalars to TensorBoard event files in ``directory``; does nothing when it
    is None (``--no-tensorboard``)."""

    def __init__(self, directory: str | Path | None):
        self.writer = None
        if directory is not None:
            from torch.utils.tensorboard import SummaryWriter

            self.writer = SummaryWriter(str(directory))

    def add(self, key: str, value: float, step: int) -> None:
        if self.writer is not None:
            self.writer.add_scalar(key, float(value), step)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
