"""Value types shared by the scenario models: numbers, points, rectangles, colours,
names and textures."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PlainSerializer,
    PrivateAttr,
    WithJsonSchema,
)

from flatland_ma.scenario.colors import COLOR_JSON_SCHEMA, color_text, parse_color
from flatland_ma.scenario.errors import Marks

MAX_GROUPS = 64
"""Item groups, zones, teams, rules and layout generators, each (the shipped scenarios
have at most 4 of any): several checks and every step go over them one by one (the work
budget, ``flatland_ma.scenario.budget``, counts the rest)."""

MAX_ARENA_SIDE = 10_000.0
"""The longest side an arena may have, in world units (the largest shipped one is 800):
it bounds every coordinate, and so the memory of the grids laid over the arena."""
MAX_FORCE = 100_000.0
"""The strongest motor force and grasp allowed (the physics is tested at these limits)."""

MIN_LENGTH = 0.1
"""The shortest length of anything physical or seen, in world units (radii, widths,
thicknesses, texture periods; the default agent has radius 10): pymunk needs shapes with a
positive area and bodies with a positive moment, and rays resolve nothing finer."""
MIN_MASS, MAX_MASS = 1e-3, 1e6
"""The lightest and heaviest body (the default agent weighs 1), so that moments of inertia
stay positive and the solver's mass ratios stay within what it handles."""
MAX_SPEED = 100_000.0
"""The fastest top speed of an agent, units per second (the default is 200)."""
MAX_FRICTION = 100.0
"""The largest friction coefficient (the defaults are 0.5)."""

Real = Annotated[float, Field(strict=True, allow_inf_nan=False)]
MAX_REWARD = 1_000_000.0
"""The largest reward (either sign) one thing gives: a step's rewards add up to a finite
number however many of them an agent gets at once."""
Reward = Annotated[float, Field(strict=True, ge=-MAX_REWARD, le=MAX_REWARD, allow_inf_nan=False)]
Positive = Annotated[float, Field(strict=True, gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(strict=True, ge=0, allow_inf_nan=False)]
Length = Annotated[float, Field(strict=True, ge=MIN_LENGTH, le=MAX_ARENA_SIDE, allow_inf_nan=False)]
"""A length of something physical or seen (radii, widths, thicknesses, periods)."""
Degrees = Annotated[float, Field(strict=True, ge=-180, le=180, allow_inf_nan=False)]
"""An angle in degrees, from -180 to 180."""
Distance = Annotated[float, Field(strict=True, ge=0, le=MAX_ARENA_SIDE, allow_inf_nan=False)]
"""A distance that may be zero (offsets, gaps), no longer than the longest arena side."""
Mass = Annotated[float, Field(strict=True, ge=MIN_MASS, le=MAX_MASS, allow_inf_nan=False)]
Speed = Annotated[float, Field(strict=True, gt=0, le=MAX_SPEED, allow_inf_nan=False)]
Friction = Annotated[float, Field(strict=True, ge=0, le=MAX_FRICTION, allow_inf_nan=False)]
UnitInterval = Annotated[float, Field(strict=True, ge=0, le=1, allow_inf_nan=False)]
Flag = Annotated[bool, Field(strict=True)]
Vec2 = tuple[Real, Real]
Size2 = tuple[Length, Length]
Color = Annotated[
    tuple[float, float, float],
    BeforeValidator(parse_color),
    PlainSerializer(color_text),
    WithJsonSchema(COLOR_JSON_SCHEMA),
]
"""A colour: written as a name, ``"#rrggbb"`` or ``[r, g, b]``; stored as three floats.

A default is written as in a file, ``Field(default="gray", validate_default=True)``:
pydantic parses it into floats, and type checkers do not hold the name against the
stored type (the JSON schema and the reference show the name)."""
Name = Annotated[str, Field(strict=True, pattern=r"^[a-z][a-z0-9_]*$", max_length=40)]
Seed = Annotated[int, Field(strict=True, ge=0, le=2**31 - 1)]
"""A seed of a random generator."""


def _ordered(rect: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    x0, y0, x1, y1 = rect
    if not (x1 > x0 and y1 > y0):
        raise ValueError(f"rectangle {list(rect)} must be [x0, y0, x1, y1] with x1 > x0, y1 > y0")
    if min(x1 - x0, y1 - y0) < MIN_LENGTH:
        raise ValueError(f"rectangle {list(rect)} must be at least {MIN_LENGTH:g} wide and high")
    return rect


RECT_JSON_SCHEMA: dict[str, Any] = {
    "type": "array",
    "prefixItems": [{"type": "number", "title": corner} for corner in ("x0", "y0", "x1", "y1")],
    "minItems": 4,
    "maxItems": 4,
}
"""A rectangle in the JSON schema, each number named for editors."""
Rect = Annotated[
    tuple[Real, Real, Real, Real], AfterValidator(_ordered), WithJsonSchema(RECT_JSON_SCHEMA)
]
"""An axis-aligned rectangle ``[x0, y0, x1, y1]`` (lower-left, then upper-right corner)."""


class Spec(BaseModel):
    """Base of every scenario model: frozen, and unknown keys are errors."""

    model_config = ConfigDict(
        extra="forbid", frozen=True, validate_default=True, use_attribute_docstrings=True
    )


class FileSpec(Spec):
    """A spec read from a file (a scenario, a suite), which remembers the file and the line
    of every key path in it, to locate the faults found after validation. Neither is a
    field: what the spec validates, serialises and compares is its fields alone."""

    _origin: tuple[str, Marks] = PrivateAttr(default=("<spec>", {}))

    @property
    def source(self) -> str:
        """The file it was read from (``<spec>`` for one made in code)."""
        return self._origin[0]

    @property
    def marks(self) -> Marks:
        """For each key path, the file and line where its value was written."""
        return self._origin[1]

    def read_from(self, source: str, marks: Marks) -> None:
        """Remember that it was read from ``source``, each key path where ``marks`` says."""
        self._origin = (source, marks)


class TextureSpec(Spec):
    """How a surface's colour varies along it (what a ray sees depends on where it hits).

    ``u`` is the distance along the surface: around a polygon from its first vertex,
    around a circle from its body's heading; textures turn with their bodies.
    """

    kind: Literal["uniform", "stripes", "tiles", "checkers", "gradient", "noise"] = "uniform"
    """uniform: the first colour. stripes: bands along u, ``duty`` of each period in the
    first colour. tiles: tiles of the first colour separated by grout lines of the second,
    ``duty`` of each period being grout. checkers: a checkerboard of squares of side
    ``period`` fixed in the world (x, y), not on the surface. gradient: from the first
    colour to the second and back over ``2 * period``. noise: cells of length ``period``,
    each a random mix of the two colours drawn from ``seed``."""
    colors: tuple[Color, Color] = Field(default=("white", "black"), validate_default=True)
    """The two colours of the pattern."""
    period: Length = 10.0
    """Length in world units of one stripe pair, tile, checker square, gradient ramp or
    noise cell."""
    duty: UnitInterval = 0.5
    """Share of each period in the first colour (stripes) or in grout (tiles)."""
    seed: Seed = 0
    """Seed of the noise pattern."""
