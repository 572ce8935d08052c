"""Memory the learner keeps from one update to the next, for speed: freed memory left
with the process (``keep_freed_memory``) and buffers that minibatches are gathered into
(``Gather``)."""

from __future__ import annotations

import ctypes
import ctypes.util

import torch
from torch.utils._pytree import tree_flatten, tree_unflatten


def keep_freed_memory() -> bool:
    """Ask glibc to keep freed memory for reuse: no trimming of the heap, and blocks up to
    its largest threshold (32 MiB) from the heap rather than from fresh mappings. Returns
    whether it was set (False off glibc)."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        return False
    M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
    return bool(mallopt(M_TRIM_THRESHOLD, 1 << 30)) and bool(mallopt(M_MMAP_THRESHOLD, 1 << 25))


class Gather:
    """Rows of a tree of tensors (rows first), gathered into buffers of this object's own
    that the next call overwrites: ``gather(tree, index)`` is ``tree_map(lambda x:
    x[index], tree)``, number for number, without a new allocation per call while
    ``index`` is no longer than before. What it returns is valid until the next call."""

    def __init__(self):
        self._buffers: list[torch.Tensor] = []

    def __call__(self, tree, index: torch.Tensor):
        leaves, spec = tree_flatten(tree)
        n = len(index)
        if len(self._buffers) != len(leaves) or any(
            b.shape[0] < n or b.shape[1:] != x.shape[1:] or b.dtype != x.dtype
            for b, x in zip(self._buffers, leaves)
        ):
            self._buffers = [x.new_empty((n, *x.shape[1:])) for x in leaves]
        rows = [torch.index_select(x, 0, index, out=b[:n]) for x, b in zip(leaves, self._buffers)]
        return tree_unflatten(rows, spec)
