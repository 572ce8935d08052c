"""The render modes of the envs: the ones the code has, and the ones this install can do
(``human`` needs pygame)."""

from __future__ import annotations

import importlib.util


def available_render_modes() -> list[str]:
    """The render modes this install can do: ``rgb_array`` always, ``human`` when pygame
    can be imported (the ``render`` extra, or ``pip install pygame``)."""
    try:
        pygame = importlib.util.find_spec("pygame")
    except (ImportError, ValueError):  # pygame set to None in sys.modules, or half-installed
        pygame = None
    return (["human"] if pygame is not None else []) + ["rgb_array"]


KNOWN_RENDER_MODES = ("human", "rgb_array")
"""The render modes the code has. An env accepts each (PettingZoo's ``render_test``
builds one with ``human`` only to read its metadata); without pygame, ``render()`` in
``human`` mode raises ``ImportError`` naming the extra to install."""
RENDER_MODES = available_render_modes()
"""The render modes of every env of this install (``metadata["render_modes"]``)."""
