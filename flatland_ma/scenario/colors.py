"""Colours in scenario files: a name, a ``"#rrggbb"`` string or ``[r, g, b]`` in 0-255.

Every colour is stored as a tuple of three floats in [0, 1], and written back (``model_dump``,
defaults in the JSON schema) as its name, or else as ``"#rrggbb"``.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from typing import Any, TypeGuard

RGB = tuple[float, float, float]

# A small, fixed palette so that files read naturally ("orange", "purple").
NAMED_COLORS_255: dict[str, tuple[int, int, int]] = {
    "black": (0, 0, 0),
    "white": (255, 255, 255),
    "gray": (128, 128, 128),
    "grey": (128, 128, 128),
    "lightgray": (200, 200, 200),
    "darkgray": (80, 80, 80),
    "red": (220, 30, 30),
    "green": (30, 170, 60),
    "lime": (120, 230, 40),
    "blue": (40, 80, 230),
    "navy": (20, 30, 120),
    "cyan": (0, 200, 220),
    "teal": (0, 128, 128),
    "yellow": (240, 220, 30),
    "gold": (200, 160, 20),
    "orange": (255, 140, 0),
    "purple": (140, 30, 170),
    "magenta": (220, 0, 200),
    "pink": (250, 150, 190),
    "brown": (130, 80, 30),
    "olive": (110, 120, 30),
    "maroon": (120, 20, 30),
    "beige": (225, 215, 180),
}


def parse_color(value: object) -> RGB:
    """Turn a colour as written in a scenario file into three floats in [0, 1].

    Raises ``ValueError`` with a message meant for the author of the file.
    """
    if isinstance(value, str):
        text = value.strip().lower()
        if text.startswith("#"):
            digits = text[1:]
            if len(digits) != 6 or any(c not in "0123456789abcdef" for c in digits):
                raise ValueError(f"colour {value!r} is not of the form '#rrggbb'")
            return _scaled([int(digits[i : i + 2], 16) for i in (0, 2, 4)])
        if text in NAMED_COLORS_255:
            return _scaled(NAMED_COLORS_255[text])
        known = ", ".join(sorted(NAMED_COLORS_255))
        close = difflib.get_close_matches(text, list(NAMED_COLORS_255), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ValueError(f"unknown colour name {value!r}{hint}; known names: {known}")
    if isinstance(value, (list, tuple)):
        if len(value) != 3 or not all(
            isinstance(c, int) and not isinstance(c, bool) for c in value
        ):
            raise ValueError(f"colour {value!r} must be three integers [r, g, b] in 0-255")
        if not all(0 <= c <= 255 for c in value):
            raise ValueError(f"colour {value!r} has a component outside 0-255")
        return _scaled(value)
    raise ValueError(f"colour {value!r} must be a name, '#rrggbb' or [r, g, b] with 0-255 integers")


def _scaled(ints: Sequence[int]) -> RGB:
    """Three components in 0-255 as three floats in [0, 1]."""
    r, g, b = ints
    return r / 255.0, g / 255.0, b / 255.0


def _is_stored(color: object) -> TypeGuard[RGB]:
    """Whether a colour is in the stored form (floats), not as a file writes it."""
    return isinstance(color, tuple) and all(isinstance(c, float) for c in color)


def color_text(color: object) -> str:
    """A colour as a file would write it: its name if it has one, else ``"#rrggbb"``.

    Takes a stored colour (three floats) or anything ``parse_color`` reads.
    """
    rgb = color if _is_stored(color) else parse_color(color)
    ints = tuple(round(c * 255) for c in rgb)
    names = [name for name, value in NAMED_COLORS_255.items() if value == ints]
    return names[0] if names else "#{:02x}{:02x}{:02x}".format(*ints)


COLOR_JSON_SCHEMA: dict[str, Any] = {
    "anyOf": [
        {"type": "string", "enum": list(NAMED_COLORS_255)},
        {"type": "string", "pattern": "^#[0-9a-fA-F]{6}$"},
        {
            "type": "array",
            "items": {"type": "integer", "minimum": 0, "maximum": 255},
            "minItems": 3,
            "maxItems": 3,
        },
    ]
}
"""What a colour may be in a file, for the JSON schema (pydantic's own would say three
numbers: the stored form). Names are matched in any case by the loader, in lower case here."""
