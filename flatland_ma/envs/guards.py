"""What the batched envs check before a call changes anything: that no other thread is
inside the env, and that the actions given are a batch (one per slot), not something else.

``OneCaller`` is the single env's guard (``FlatlandParallelEnv.enter``) for the envs of many
worlds: pymunk spaces are not thread-safe, and a sharded env's pipes carry one call's
messages at a time (two threads would take each other's answers and wait for ever), so a
second thread calling in at the same time gets a clear ``RuntimeError`` and the env is
left as it was.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping

import gymnasium
import numpy as np


class OneCaller:
    """A non-blocking claim on an env: ``with guard:`` around each call that steps, resets
    or reads it; a second thread entering meanwhile raises ``RuntimeError``. It pickles as a
    fresh, free guard."""

    def __init__(self, what: str = "this env"):
        self.what = what
        self._lock = threading.Lock()

    def __enter__(self) -> OneCaller:
        if not self._lock.acquire(blocking=False):
            raise RuntimeError(
                f"{self.what} is in use by another thread at the same time; its worlds (their "
                "pymunk spaces, its processes' pipes) serve one call at a time: make one env "
                "per thread, or call it from one thread"
            )
        return self

    def __exit__(self, *exc) -> None:
        self._lock.release()

    def __reduce__(self):
        return (OneCaller, (self.what,))


def check_batch_of_actions(actions, num_slots: int, single: gymnasium.Space, layout: str) -> None:
    """Raise ``TypeError`` unless ``actions`` is a batch (an array or a sequence, one action
    in ``single`` per slot), ``ValueError`` if it has the wrong length; ``layout`` says
    which slot is which (e.g. "2 worlds x 3 agents"). Nothing is changed."""

    def takes() -> str:  # worded only for an error: the space's text costs a step's microseconds
        return (
            f"a batch's step takes one action per slot ({num_slots}: {layout}), as an array "
            f"or a sequence of length {num_slots} whose entries lie in {single}"
        )

    if isinstance(actions, Mapping):
        raise TypeError(
            f"{takes()}; got a {type(actions).__name__} (a PettingZoo-style dict of agent name "
            "-> action is what FlatlandParallelEnv.step takes; here slot "
            "w * agents_per_world + j is world w's agent j)"
        )
    if (
        actions is None
        or isinstance(actions, str | bytes)
        or not (hasattr(actions, "__len__") and hasattr(actions, "__getitem__"))
    ):
        raise TypeError(f"{takes()}; got {_shown(actions)}")
    try:
        n = len(actions)
    except TypeError:  # a 0-d array
        raise TypeError(f"{takes()}; got {_shown(actions)}") from None
    if n != num_slots:
        raise ValueError(f"expected one action per slot ({num_slots}: {layout}), got {n}")


def _shown(value) -> str:
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    text = repr(value)
    return f"{text[:60]}..." if len(text) > 60 else text
