"""Textures: the colour a ray returns depends on where it hits the surface."""

import numpy as np
import pytest

import flatland_ma
from flatland_ma.sensors import textures as tx
from tests.kernel_helpers import box, cast

A, B = (1.0, 0.5, 0.0), (0.0, 0.25, 1.0)
# A wall whose near face is x = 50, from y = 200 down to y = -200 (edge 3 of the box, which
# starts at u = 20 + 400 + 20 = 440 along the perimeter).
WALL = box(60.0, 0.0, 20.0, 400.0)
FACE_U0 = 440.0


def face_colours(texture, angles):
    distance, _, image = cast(angles, polygons=[WALL], colors=[A], textures=[texture], falloff=1)
    hit_y = distance * np.sin(angles)
    return hit_y, image[:, :3]


ANGLES = np.radians(np.linspace(-70, 70, 141))


def expected(w):
    return np.outer(1 - w, A) + np.outer(w, B)


def test_stripes_follow_the_distance_along_the_surface():
    hit_y, colours = face_colours((tx.STRIPES, 7.0, 0.3, 0, B), ANGLES)
    u = FACE_U0 + (200.0 - hit_y)
    f = u / 7.0 - np.floor(u / 7.0)
    w = np.where(f < 0.3, 0.0, 1.0)
    np.testing.assert_allclose(colours, expected(w), atol=1e-6)
    assert 0 < w.mean() < 1  # both colours are seen


def test_tiles_put_grout_lines_of_the_second_colour():
    hit_y, colours = face_colours((tx.TILES, 10.0, 0.2, 0, B), ANGLES)
    u = FACE_U0 + (200.0 - hit_y)
    f = u / 10.0 - np.floor(u / 10.0)
    np.testing.assert_allclose(colours, expected(np.where(f < 0.2, 1.0, 0.0)), atol=1e-6)


def test_checkers_are_fixed_in_the_world():
    hit_y, colours = face_colours((tx.CHECKERS, 12.0, 0.5, 0, B), ANGLES)
    parity = (np.floor(50.0 / 12.0) + np.floor(hit_y / 12.0)) % 2
    np.testing.assert_allclose(colours, expected(parity), atol=1e-5)


def test_gradient_ramps_up_and_down():
    hit_y, colours = face_colours((tx.GRADIENT, 50.0, 0.5, 0, B), ANGLES)
    u = FACE_U0 + (200.0 - hit_y)
    f = u / 50.0 - 2 * np.floor(u / 100.0)
    w = np.where(f < 1, f, 2 - f)
    np.testing.assert_allclose(colours, expected(w), atol=1e-5)


def test_noise_is_fixed_by_its_seed():
    _, first = face_colours((tx.NOISE, 5.0, 0.5, 3, B), ANGLES)
    _, again = face_colours((tx.NOISE, 5.0, 0.5, 3, B), ANGLES)
    _, other = face_colours((tx.NOISE, 5.0, 0.5, 4, B), ANGLES)
    np.testing.assert_array_equal(first, again)
    assert not np.allclose(first, other)
    w = (first[:, 2] - A[2]) / (B[2] - A[2])
    assert len(np.unique(np.round(w, 6))) > 10 and 0 <= w.min() and w.max() <= 1


def test_circle_textures_turn_with_their_body():
    angles = np.radians(np.linspace(-5, 5, 21))
    texture = (tx.STRIPES, 3.0, 0.5, 0, B)
    looks = []
    for body_angle in (0.0, 0.4):
        _, _, image = cast(
            angles,
            circles=[(0.0, 0.0, 10.0)],
            eye=(-50.0, 0.0, 0.0),
            colors=[A],
            textures=[texture],
            poses=[(0.0, 0.0, body_angle)],
            circle_bodies=[0],
            falloff=1,
        )
        looks.append(image[:, :3])
    assert not np.allclose(looks[0], looks[1])


def test_textured_fruits_differ_in_pattern_not_in_mean_colour():
    env = flatland_ma.parallel_env("textured_fruits", obstacles=[])
    env.reset(seed=0)
    spec = env.spec.items
    fruit, poison = spec[0].texture, spec[1].texture
    assert spec[0].color == spec[1].color and fruit.colors == poison.colors
    assert fruit.kind != poison.kind
    seen = env.episode.sensors.hit_entity
    assert (seen >= 0).any()


@pytest.mark.parametrize("kind", list(tx.KINDS))
def test_every_texture_kind_renders_and_stays_in_the_observation_space(kind):
    texture = {"kind": kind, "colors": ["white", "red"], "period": 6}
    env = flatland_ma.parallel_env("fruits_poisons", arena={"wall": {"texture": texture}})
    observations, _ = env.reset(seed=0)
    for _ in range(20):
        assert env.observation_space("agent_0").contains(observations["agent_0"])
        observations, *_ = env.step({"agent_0": 1})
    assert np.isfinite(observations["agent_0"]).all()
