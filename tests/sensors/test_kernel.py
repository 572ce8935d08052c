"""The ray kernel against analytic geometry."""

import math
from pathlib import Path

import numpy as np
import pytest

import flatland_ma
from flatland_ma.sensors import cull, kernel
from flatland_ma.sensors.scene import Outputs, pack_eyes, pack_scene
from flatland_ma.sensors.sensor_suite import compiled_kernel
from tests import kernel_reference
from tests.kernel_helpers import box, cast, deg

WALL = box(60.0, 0.0, 20.0, 400.0)  # its near face is the line x = 50


def test_wall_straight_ahead_and_at_an_angle():
    angles = np.radians(np.linspace(-60, 60, 25))
    distance, hit, _ = cast(angles, polygons=[WALL])
    np.testing.assert_allclose(distance, 50.0 / np.cos(angles), rtol=1e-12)
    assert (hit == 0).all()


def test_wall_seen_from_a_rotated_and_translated_eye():
    # Eye at (10, 30) heading 30 degrees: the ray at -30 degrees points along +x.
    distance, _, _ = cast(deg(-30.0, 0.0), eye=(10.0, 30.0, math.radians(30)), polygons=[WALL])
    assert distance[0] == pytest.approx(40.0, rel=1e-12)
    assert distance[1] == pytest.approx(40.0 / math.cos(math.radians(30)), rel=1e-12)


@pytest.mark.parametrize("angle_deg", [0.0, 3.0, -4.5, 5.5])
def test_circle_hit_matches_the_quadratic(angle_deg):
    cx, r = 100.0, 10.0
    a = math.radians(angle_deg)
    expected = cx * math.cos(a) - math.sqrt(r * r - (cx * math.sin(a)) ** 2)
    distance, hit, _ = cast([a], circles=[(cx, 0.0, r)])
    assert hit[0] == 0
    assert distance[0] == pytest.approx(expected, rel=1e-12)


def test_near_tangent_rays_hit_inside_and_miss_outside():
    cx, r = 100.0, 10.0
    tangent = math.asin(r / cx)
    just_in, just_out = tangent - 1e-9, tangent + 1e-9
    distance, hit, _ = cast([just_in, just_out, -just_in, -just_out], circles=[(cx, 0.0, r)])
    assert list(hit) == [0, -1, 0, -1]
    assert distance[0] == pytest.approx(math.sqrt(cx * cx - r * r), rel=1e-3)
    assert distance[1] == 1000.0


def test_nearest_shape_occludes_the_ones_behind():
    circles = [(200.0, 0.0, 10.0), (100.0, 0.0, 10.0), (150.0, 0.0, 30.0)]
    distance, hit, _ = cast([0.0], polygons=[box(300.0, 0.0, 20.0, 400.0)], circles=circles)
    assert hit[0] == 2  # the circle at x = 100 (entities: polygon 0, circles 1, 2, 3)
    assert distance[0] == pytest.approx(90.0)
    # Behind the wall nothing counts; in front of it the wall is occluded.
    distance, hit, _ = cast([0.0], polygons=[WALL], circles=[(200.0, 0.0, 10.0)])
    assert (hit[0], distance[0]) == (0, pytest.approx(50.0))


def test_rays_that_hit_nothing_are_black_at_full_depth():
    distance, hit, image = cast(deg(-10, 0, 10), circles=[(0.0, 100.0, 5.0)], view_range=300.0)
    assert list(hit) == [-1, -1, -1]
    assert (distance == 300.0).all()
    np.testing.assert_array_equal(image, [[0, 0, 0, 1]] * 3)


def test_shapes_beyond_range_are_not_seen():
    distance, hit, _ = cast([0.0], circles=[(120.0, 0.0, 10.0)], view_range=100.0)
    assert hit[0] == -1 and distance[0] == 100.0
    distance, hit, _ = cast([0.0], circles=[(105.0, 0.0, 10.0)], view_range=100.0)
    assert hit[0] == 0 and distance[0] == pytest.approx(95.0)


def test_polygons_are_seen_from_outside_only():
    # From inside a box the rays pass through its (back-facing) edges.
    distance, hit, _ = cast(deg(0, 90, 180), polygons=[box(0.0, 0.0, 40.0, 40.0)])
    assert (hit == -1).all()
    distance, hit, _ = cast([0.0], eye=(-100.0, 0.0, 0.0), polygons=[box(0.0, 0.0, 40.0, 40.0)])
    assert distance[0] == pytest.approx(80.0)


def test_ray_through_a_shared_vertex_does_not_leak():
    # A diamond: the ray along +x meets the vertex (80, 0) where two edges join.
    diamond = [(100.0, -20.0), (120.0, 0.0), (100.0, 20.0), (80.0, 0.0)]
    distance, hit, _ = cast([0.0], polygons=[diamond])
    assert hit[0] == 0 and distance[0] == pytest.approx(80.0)


def test_an_eye_does_not_see_shapes_of_its_own_agent():
    circles = [(20.0, 0.0, 5.0), (60.0, 0.0, 5.0)]
    distance, hit, _ = cast([0.0], circles=circles, owners=[3, 4], eye_owner=3)
    assert hit[0] == 1 and distance[0] == pytest.approx(55.0)
    distance, hit, _ = cast([0.0], circles=circles, owners=[3, 4], eye_owner=7)
    assert hit[0] == 0


def test_an_eye_inside_a_circle_sees_it_at_distance_zero():
    distance, hit, image = cast([0.0], circles=[(0.0, 0.0, 5.0)], colors=[(0.2, 0.4, 0.6)])
    assert hit[0] == 0 and distance[0] == 0.0
    np.testing.assert_allclose(image[0], [0.2, 0.4, 0.6, 0.0], rtol=1e-6)


def test_colour_intensity_falls_linearly_with_distance():
    colour = (1.0, 0.5, 0.25)
    _, _, image = cast([0.0], polygons=[WALL], colors=[colour], view_range=200.0)
    np.testing.assert_allclose(image[0, :3], np.array(colour) * (1 - 50 / 200), rtol=1e-6)
    assert image[0, 3] == pytest.approx(0.25)
    _, _, image = cast(
        [0.0], polygons=[WALL], colors=[colour], view_range=200.0, falloff=kernel.FALLOFF_NONE
    )
    np.testing.assert_allclose(image[0, :3], colour, rtol=1e-6)


def test_shapes_on_moving_bodies_follow_their_pose():
    # A 20 x 20 box in body coordinates, its body at (100, 0) turned 45 degrees: the ray
    # along +x meets the corner at x = 100 - 10 * sqrt(2).
    local = box(0.0, 0.0, 20.0, 20.0)
    distance, _, _ = cast(
        [0.0], polygons=[local], poses=[(100.0, 0.0, math.pi / 4)], polygon_bodies=[0]
    )
    assert distance[0] == pytest.approx(100.0 - 10.0 * math.sqrt(2.0))
    # A circle offset (10, 0) on a body at (50, 50) turned 90 degrees sits at (50, 60).
    distance, _, _ = cast(
        [math.pi / 2],
        eye=(50.0, 0.0, 0.0),
        circles=[(10.0, 0.0, 5.0)],
        poses=[(50.0, 50.0, math.pi / 2)],
        circle_bodies=[0],
    )
    assert distance[0] == pytest.approx(55.0)


def test_an_eye_on_a_body_moves_and_turns_with_it():
    distance, _, _ = cast(
        [0.0], eye=(0.0, 0.0, 0.0), polygons=[WALL], poses=[(20.0, 0.0, 0.0)], eye_body=0
    )
    assert distance[0] == pytest.approx(30.0)
    distance, hit, _ = cast(
        [0.0], eye=(0.0, 0.0, math.pi), polygons=[WALL], poses=[(20.0, 0.0, math.pi)], eye_body=0
    )
    assert distance[0] == pytest.approx(30.0) and hit[0] == 0  # turned twice by pi


def test_field_of_view_culling_keeps_long_walls_whose_middle_is_out_of_view():
    # A long wall across the view whose midpoint lies far to the left, outside a narrow FOV.
    wall = [(50.0, -10.0), (60.0, -10.0), (60.0, 2000.0), (50.0, 2000.0)]
    distance, hit, _ = cast(
        deg(-2, 0, 2), polygons=[wall], half_fov=math.radians(2), view_range=5000.0
    )
    assert (hit == 0).all()
    np.testing.assert_allclose(distance, 50.0 / np.cos(np.radians([-2, 0, 2])))


def test_culling_agrees_with_brute_force_on_random_scenes():
    rng = np.random.default_rng(0)
    for _ in range(30):
        circles = [(*rng.uniform(-300, 300, 2), rng.uniform(2, 30)) for _ in range(15)]
        polys = [box(*rng.uniform(-300, 300, 2), *rng.uniform(5, 80, 2)) for _ in range(8)]
        heading = rng.uniform(-math.pi, math.pi)
        angles = np.radians(np.linspace(-50, 50, 41))
        eye = (0.0, 0.0, heading)
        distance, hit, _ = cast(angles, eye=eye, polygons=polys, circles=circles, view_range=250.0)
        # Brute force: the nearest hit over every shape, no culling.
        for i, a in enumerate(angles):
            alone = {}  # shape index -> distance at which this ray hits it on its own
            for e, p in enumerate(polys):
                d, h, _ = cast([a], eye=eye, polygons=[p], view_range=250.0, half_fov=math.pi)
                if h[0] >= 0:
                    alone[e] = d[0]
            for k, c in enumerate(circles):
                d, h, _ = cast([a], eye=eye, circles=[c], view_range=250.0, half_fov=math.pi)
                if h[0] >= 0:
                    alone[len(polys) + k] = d[0]
            best = min(alone.values(), default=250.0)
            assert distance[i] == pytest.approx(best, abs=1e-9)
            # The nearest shape is the one reported; shapes tied with it (overlapping
            # boundaries) are equally right.
            nearest = {who for who, d in alone.items() if abs(d - best) <= 1e-9}
            assert hit[i] in (nearest or {-1}), (i, hit[i], nearest)


@pytest.mark.parametrize("cells", [1, 7, 64, 1024])
def test_grid_walk_finds_exactly_what_brute_force_finds(cells):
    rng = np.random.default_rng(cells)
    for _ in range(25):
        circles = [(*rng.uniform(-300, 300, 2), rng.uniform(2, 30)) for _ in range(12)]
        polys = [box(*rng.uniform(-300, 300, 2), *rng.uniform(2, 120, 2)) for _ in range(10)]
        # Eyes inside and outside the grid's extent; rays along the axes and diagonals too.
        eye = (
            *rng.uniform(-450, 450, 2),
            rng.choice([0.0, math.pi / 2, math.pi / 4, rng.uniform(-4, 4)]),
        )
        angles = np.radians(np.concatenate([np.linspace(-90, 90, 37), [0.0, 45.0, -45.0]]))
        kwargs = dict(eye=eye, polygons=polys, circles=circles, view_range=400.0, half_fov=math.pi)
        d_grid, h_grid, img_grid = cast(angles, grid=True, cells=cells, **kwargs)
        d_all, h_all, img_all = cast(angles, grid=False, **kwargs)
        np.testing.assert_allclose(d_grid, d_all, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(h_grid, h_all)
        np.testing.assert_allclose(img_grid, img_all, atol=1e-7)


def test_an_eye_exactly_on_grid_lines_sees_the_wall():
    # The wall's box spans the grid; eyes on cell corners, rays along the grid lines.
    for eye in [(0.0, 0.0, 0.0), (25.0, 25.0, math.pi / 2), (-10.0, 0.0, math.pi)]:
        walls = [
            box(60.0, 0.0, 20.0, 400.0),
            box(0.0, 60.0, 400.0, 20.0),
            box(-60.0, 0.0, 20.0, 400.0),
        ]
        d_grid, h_grid, _ = cast([0.0, 0.3], eye=eye, polygons=walls, cells=16)
        d_all, h_all, _ = cast([0.0, 0.3], eye=eye, polygons=walls, grid=False)
        np.testing.assert_allclose(d_grid, d_all, atol=1e-9)
        np.testing.assert_array_equal(h_grid, h_all)


# The faster kernel (issue 29) against the frozen one before it: bit for bit.

SCENARIOS = sorted(p.stem for p in (Path(__file__).parents[2] / "scenarios").glob("*.yaml"))


def _outputs_equal(a: Outputs, b: Outputs) -> bool:
    return all(x.tobytes() == y.tobytes() for x, y in zip(a, b))


@pytest.mark.parametrize("name", SCENARIOS)
def test_every_scenario_sees_bit_for_bit_what_the_old_kernel_saw(name):
    env = flatland_ma.parallel_env(name)
    env.reset(seed=3)
    for a in env.possible_agents:
        env.action_space(a).seed(7)
    rays = 0
    for _ in range(150):
        if not env.agents:
            env.reset()
        env.step({a: env.action_space(a).sample() for a in env.agents})
        sensors = env.running.sensors
        args = sensors.kernel_args
        old = Outputs.zeros(len(sensors.distance))
        compiled_kernel(args, kernel_reference.observe)(*args[:5], old, args[6])
        assert _outputs_equal(sensors.out, old), name
        rays += len(old.distance)
    assert rays > 0 or name in {"scent_rooms", "signal_maps"}  # the two without rays


def _random_scene(rng):
    """Fixed and moving polygons and circles, owners, textures and an eye, at random."""
    n_poly, n_circ = 8, 14
    polys = [box(0.0, 0.0, *rng.uniform(3, 90, 2)) for _ in range(n_poly)]
    circles = [(*rng.uniform(-8, 8, 2), rng.uniform(1, 25)) for _ in range(n_circ)]
    poses = [(*rng.uniform(-300, 300, 2), rng.uniform(-4, 4)) for _ in range(n_poly + n_circ)]
    on_body = rng.random(n_poly + n_circ) < 0.6  # the rest are fixed, moved into the world
    fixed_polys = [[(x + p[0], y + p[1]) for x, y in c] for c, p in zip(polys, poses)]
    kinds = [None, (1, 9.0, 0.5, 0.0, (0.2, 0.9, 0.1)), (2, 14.0, 0.3, 5.0, (0.0, 0.0, 1.0))]
    return dict(
        polygons=[c if b else f for c, f, b in zip(polys, fixed_polys, on_body)],
        circles=[
            c if b else (c[0] + p[0], c[1] + p[1], c[2])
            for c, p, b in zip(circles, poses[n_poly:], on_body[n_poly:])
        ],
        polygon_bodies=[k if b else -1 for k, b in enumerate(on_body[:n_poly])],
        circle_bodies=[n_poly + k if b else -1 for k, b in enumerate(on_body[n_poly:])],
        poses=poses,
        owners=list(rng.integers(-1, 3, n_poly + n_circ)),
        eye_owner=int(rng.integers(-1, 3)),
        colors=rng.uniform(0, 1.2, (n_poly + n_circ, 3)),
        textures=[kinds[int(rng.integers(3))] for _ in range(n_poly + n_circ)],
        eye=(*rng.uniform(-420, 420, 2), rng.uniform(-4, 4)),  # in the grid and out of it
        view_range=float(rng.choice([150.0, 400.0, 2000.0])),
        cells=int(rng.choice([1, 16, 256])),
    )


def _fans(rng, n):
    """Evenly spaced fans both ways, narrow to a full turn, and uneven ones."""
    fov = float(rng.choice([0.2, 2.06, math.pi, 2 * math.pi - 0.01, 2 * math.pi]))
    even = fov * (0.5 - (np.arange(n) + 0.5) / n)
    return [even, even[::-1].copy(), np.sort(rng.uniform(-2, 2, n)), rng.uniform(-4, 4, n)]


@pytest.mark.parametrize("seed", range(6))
def test_random_scenes_and_fans_give_bit_for_bit_what_the_old_kernel_gave(seed):
    rng = np.random.default_rng(seed)
    reference = kernel_reference.observe
    for _ in range(12):
        scene = _random_scene(rng)
        for angles in _fans(rng, int(rng.choice([1, 2, 64, 333]))):
            for falloff in (kernel.FALLOFF_LINEAR, kernel.FALLOFF_NONE):
                half = float(np.abs(angles).max())
                new = cast(angles, falloff=falloff, half_fov=half, **scene)
                old = cast(angles, falloff=falloff, half_fov=half, observe=reference, **scene)
                for x, y in zip(new, old):
                    assert x.tobytes() == y.tobytes()


def test_fast_atan2_is_within_its_stated_error():
    rng = np.random.default_rng(0)
    y, x = rng.normal(size=(2, 20_000)) * rng.choice([1e-6, 1.0, 1e6], (2, 20_000))
    error = max(abs(cull.fast_atan2(a, b) - math.atan2(a, b)) for a, b in zip(y, x))
    assert error < 2e-6 < cull.PAD / 10
    for a, b in [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (0.0, 0.0), (1.0, 1.0)]:
        assert cull.fast_atan2(a, b) == pytest.approx(math.atan2(a, b), abs=2e-6)


@pytest.mark.parametrize("step_sign", [1.0, -1.0])
def test_ray_span_holds_every_ray_within_the_width_and_few_others(step_sign):
    rng = np.random.default_rng(1)
    for n, fov in [(64, 2.06), (7, 0.3), (360, 2 * math.pi - 2 * math.pi / 360)]:
        angles = step_sign * np.linspace(-fov / 2, fov / 2, n)
        fan = np.array([angles[0], angles[1] - angles[0]])
        for _ in range(300):
            theta, width = rng.uniform(-2 * math.pi, 2 * math.pi), rng.uniform(0, 0.5)
            first, last = cull.ray_span(fan, n, theta, width)
            gap = np.abs((angles - theta + math.pi) % (2 * math.pi) - math.pi)
            inside = np.flatnonzero(gap <= width)
            if len(inside):
                assert first <= inside.min() and inside.max() <= last
            if first <= last and last - first + 1 < n:  # a span, not all rays: a tight one
                assert last - first + 1 <= len(inside) + 2


def test_uneven_or_single_rays_have_no_fan_and_are_all_tested():
    eyes = pack_eyes(
        body=[-1, -1, -1],
        local=[(0.0, 0.0, 0.0)] * 3,
        owner=[-1] * 3,
        view_range=[1.0] * 3,
        half_fov=[1.0] * 3,
        falloff=[0] * 3,
        angles=[np.array([0.5, 0.0, -0.5]), np.array([0.0, 0.1, 0.3]), np.array([0.2])],
    )
    np.testing.assert_array_equal(eyes.fan, [[0.5, -0.5], [0.0, 0.0], [0.2, 0.0]])
    assert cull.ray_span(eyes.fan[1], 3, 2.5, 0.01) == (0, 2)


def test_cells_are_marked_full_exactly_when_they_list_a_shape():
    _, grid, _ = pack_scene(
        [(box(0.0, 0.0, 10.0, 10.0), -1, 0), (box(200.0, 50.0, 300.0, 4.0), -1, 1)],
        [((-90.0, 80.0, 6.0), 0.0, -1, 2)],
        fixed=[True, True, True],
        owner=[-1] * 3,
        visible=[True] * 3,
        colors=[(1.0,) * 6] * 3,
        textures=[(0, 0.0, 0.0, 0.0)] * 3,
        target_cells=100,
    )
    listed = (np.diff(grid.cell_seg_start) > 0) | (np.diff(grid.cell_circ_start) > 0)
    np.testing.assert_array_equal(grid.cell_full, listed)
    assert 0 < grid.cell_full.sum() < len(grid.cell_full)


def test_discs_wholly_behind_a_narrow_eye_are_out_of_view_as_the_cull_assumes():
    rng = np.random.default_rng(2)
    checked = 0
    for _ in range(20_000):
        heading = rng.uniform(-math.pi, math.pi)
        hx, hy = math.cos(heading), math.sin(heading)
        dx, dy = rng.uniform(-400, 400, 2)
        radius = rng.uniform(0.1, 60.0)
        half_fov = rng.uniform(0.0, cull.BEHIND_FOV)
        if hx * dx + hy * dy < -radius and 4 * radius * radius < dx * dx + dy * dy:
            assert not cull.in_view(dx, dy, radius, 1e4, hx, hy, half_fov)
            first, last = cull.disc_rays(
                dx, dy, radius, 1e4, hx, hy, half_fov, np.array([half_fov, -0.01]), 64
            )
            assert first > last
            checked += 1
    assert checked > 5_000
