"""Pictures: the top-down view with every field of view, and the panel of every agent's
senses (camera strips, and every other sensor drawn from its reading's shape)."""

import sys

import gymnasium
import numpy as np
import pytest
from gymnasium import spaces

import flatland_ma
from flatland_ma.render import renderer as topdown
from flatland_ma.render import senses
from flatland_ma.render.video import save_gif
from flatland_ma.sensors.camera import Camera
from flatland_ma.sensors.semantic import SEMANTIC_COLORS
from flatland_ma.sensors.sensor import Sensor

SENSES = {
    "sensors": [
        {"type": "camera", "channels": ["rgb", "depth", "semantic"]},
        {"type": "lidar"},
        {"type": "proprioception"},
    ]
}
"""Several sensors per agent: a camera with every channel, a lidar and proprioception."""


def strip_row(frame, where, row: int = 0) -> np.ndarray:
    """The middle line of strip ``row`` of a sensor's slot in the frame."""
    y = where.y + row * (senses.STRIP_HEIGHT + senses.STRIP_GAP) + senses.STRIP_HEIGHT // 2
    return frame[y, where.x : where.x + where.slot.width]


def draw(env) -> tuple[np.ndarray, topdown.Renderer]:
    """The env's frame, and the renderer that drew it (its layout)."""
    frame = env.render()
    assert frame is not None and env._renderer is not None
    return frame, env._renderer


def reading(observation, name: str | None = None) -> np.ndarray:
    """One sensor's reading out of an observation (the whole of it, or its entry)."""
    value = observation if name is None else observation[name]
    assert isinstance(value, np.ndarray)
    return value


def centres(n: int, width: int) -> np.ndarray:
    """The pixel at the middle of each of n cells stretched over ``width`` pixels."""
    return ((np.arange(n) + 0.5) * width / n).astype(int)


def test_frames_have_a_fixed_size_and_show_each_agents_strips():
    env = flatland_ma.parallel_env("fruits_poisons_multi", render_mode="rgb_array")
    observations, _ = env.reset(seed=2)
    frame, renderer = draw(env)
    assert frame.dtype == np.uint8 and frame.shape == (renderer.size[1], renderer.size[0], 3)
    for _ in range(10):
        observations, *_ = env.step({a: 0 for a in env.agents})
    frame, _ = draw(env)
    assert frame.shape == (renderer.size[1], renderer.size[0], 3)
    for i, agent in enumerate(env.possible_agents):
        (where,) = renderer.placed[i]
        colour, depth = strip_row(frame, where, 0), strip_row(frame, where, 1)
        image = reading(observations[agent])
        cells = centres(len(image), where.slot.width)
        np.testing.assert_allclose(colour[cells], np.clip(image[:, :3], 0, 1) * 255, atol=1.0)
        near = (1 - image[:, 3]) * 255
        np.testing.assert_allclose(depth[cells], np.repeat(near[:, None], 3, 1), atol=1.0)


def test_every_sensor_of_every_agent_has_its_labelled_picture():
    env = flatland_ma.parallel_env("fruits_poisons_multi", render_mode="rgb_array", agent=SENSES)
    observations, _ = env.reset(seed=4)
    for _ in range(8):
        observations, *_ = env.step({a: 0 for a in env.agents})
    frame, renderer = draw(env)
    assert [len(placed) for placed in renderer.placed] == [3, 3, 3, 3]
    assert renderer.columns == 2 and frame.shape[0] == renderer.size[1] < 1000
    for i, agent in enumerate(env.possible_agents):
        camera, lidar, proprioception = renderer.placed[i]
        assert (camera.slot.style, lidar.slot.style, proprioception.slot.style) == (
            "strips",
            "strips",
            "bars",
        )
        seen = observations[agent]
        # The semantic row: each ray's kind in its fixed colour.
        kinds = reading(seen, "camera")[:, 4].astype(int)
        row = strip_row(frame, camera, 2)[centres(len(kinds), camera.slot.width)]
        np.testing.assert_array_equal(row, SEMANTIC_COLORS[kinds])
        # The lidar: a heat strip of its distances over its range 0..1.
        ring = reading(seen, "lidar")
        row = strip_row(frame, lidar)[centres(len(ring), lidar.slot.width)]
        np.testing.assert_array_equal(row, senses.heat(ring))
        # Proprioception: bars from the zero line, within the slot.
        bars = frame[
            proprioception.y : proprioception.y + proprioception.slot.height,
            proprioception.x : proprioception.x + proprioception.slot.width,
        ]
        assert (bars == senses.BAR_COLOR).all(axis=2).any()
    # Labels: each agent's header and its sensors' names are drawn (text is not blank).
    x, y = renderer.blocks[1]
    header = frame[y : y + topdown.HEADER_HEIGHT, x : x + renderer.block_size[0]]
    assert (np.abs(header.astype(int) - topdown.BACKGROUND).sum(axis=2) > 60).sum() > 50


def test_several_cameras_each_get_their_strips():
    cameras = {
        "sensors": [
            {"type": "camera", "name": "front", "rays": 32},
            {"type": "camera", "name": "wide", "rays": 8, "fov": 300, "channels": ["semantic"]},
        ]
    }
    env = flatland_ma.parallel_env("fruits_poisons_multi", render_mode="rgb_array", agent=cameras)
    observations, _ = env.reset(seed=0)
    frame, renderer = draw(env)
    for i, agent in enumerate(env.possible_agents):
        front, wide = renderer.placed[i]
        assert wide.slot.height == senses.STRIP_HEIGHT  # one channel, one strip
        image = reading(observations[agent], "front")
        row = strip_row(frame, front)[centres(32, front.slot.width)]
        np.testing.assert_allclose(row, np.clip(image[:, :3], 0, 1) * 255, atol=1.0)
        kinds = reading(observations[agent], "wide")[:, 0].astype(int)
        row = strip_row(frame, wide)[centres(8, wide.slot.width)]
        np.testing.assert_array_equal(row, SEMANTIC_COLORS[kinds])


def test_one_hot_semantic_is_drawn_in_the_same_colours():
    camera = Camera(rays=6, channels=("semantic",), semantic="onehot")
    reading = np.eye(len(SEMANTIC_COLORS), dtype=np.float32)
    np.testing.assert_array_equal(camera.picture(reading)[0], SEMANTIC_COLORS)


class Sense(Sensor):
    """A made-up sensor of any shape (no kind: it is not registered anywhere)."""

    def __init__(self, space, drawn=None):
        self.name, self.mount, self.space, self.drawn = "made_up", "base", space, drawn

    def read(self, results, k):
        return self.space.sample()

    def picture(self, reading):
        return self.drawn


def test_a_new_sensor_kind_is_drawn_from_its_shape():
    width = 200
    short = Sense(spaces.Box(-2.0, 2.0, (4,), np.float32))
    slot = senses.plan(short, width)
    assert slot == senses.Slot("bars", width, senses.BAR_HEIGHT)
    picture = senses.draw(short, np.array([2, -2, 0, 1], np.float32), slot)
    bar = picture[:, centres(4, width)]  # one column through the middle of each bar
    lit = (bar == senses.BAR_COLOR).all(axis=2)
    middle = (slot.height - 1) // 2
    assert lit[:middle, 0].all() and lit[middle + 1 :, 1].all()  # full up, full down
    assert lit[:, 2].sum() <= 2 and 0 < lit[:middle, 3].sum() < middle  # zero, half up

    long = Sense(spaces.Box(0.0, 10.0, (40,), np.float32))
    slot = senses.plan(long, width)
    assert slot.style == "strips" and slot.height == senses.STRIP_HEIGHT
    values = np.linspace(0, 10, 40, dtype=np.float32)
    row = senses.draw(long, values, slot)[senses.STRIP_HEIGHT // 2, centres(40, width)]
    np.testing.assert_array_equal(row, senses.heat(values / 10))

    table = Sense(spaces.Box(0.0, 1.0, (16, 3), np.float32))
    slot = senses.plan(table, width)
    assert slot.style == "strips" and slot.height == 3 * senses.STRIP_HEIGHT + 2 * senses.STRIP_GAP

    rgb = Sense(spaces.Box(0, 255, (8, 16, 3), np.uint8))
    slot = senses.plan(rgb, width)
    assert slot == senses.Slot("image", 192, 96)  # as tall as allowed, in proportion
    image = np.random.default_rng(0).integers(0, 256, (8, 16, 3)).astype(np.uint8)
    drawn = senses.draw(rgb, image, slot)
    np.testing.assert_array_equal(drawn[::12, ::12], image)

    grey = Sense(spaces.Box(0.0, 4.0, (10, 10, 2), np.float32))
    slot = senses.plan(grey, width)
    reading = np.zeros((10, 10, 2), np.float32)
    reading[:5, :, 0] = 4.0
    drawn = senses.draw(grey, reading, slot)
    assert slot.style == "image" and drawn.shape == (slot.height, slot.width, 3)
    assert (drawn[0] == 255).all() and (drawn[-1] == 0).all()


def test_a_sensors_own_picture_replaces_the_generic_one():
    strip = np.array([[[255, 0, 0], [0, 0, 255]]], np.uint8)
    sensor = Sense(spaces.Box(0.0, 1.0, (5,), np.float32), drawn=strip)
    slot = senses.plan(sensor, 100)
    assert slot.style == "strips" and slot.height == senses.STRIP_HEIGHT
    drawn = senses.draw(sensor, np.zeros(5, np.float32), slot)
    assert (drawn[:, :50] == (255, 0, 0)).all() and (drawn[:, 50:] == (0, 0, 255)).all()
    assert senses.draw(sensor, None, slot).shape == (slot.height, 100, 3)  # no reading yet


def test_the_panel_shows_the_noisy_reading_the_agent_got():
    noisy = {"sensors": [{"type": "lidar", "noise": {"gaussian": 0.2, "dropout": 0.3}}]}
    env = flatland_ma.parallel_env("fruits_poisons", render_mode="rgb_array", agent=noisy)
    observations, _ = env.reset(seed=0)
    frame, renderer = draw(env)
    (where,) = renderer.placed[0]
    ring = reading(observations["agent_0"])
    row = strip_row(frame, where)[centres(len(ring), where.slot.width)]
    np.testing.assert_array_equal(row, senses.heat(ring))


def test_rendering_changes_no_trajectory_nor_the_generator():
    noisy = {"sensors": [{**s, "noise": {"gaussian": 0.05}} for s in SENSES["sensors"]]}

    def run(render: bool):
        env = flatland_ma.parallel_env("fruits_poisons_multi", render_mode="rgb_array", agent=noisy)
        observations, _ = env.reset(seed=7)
        choose = np.random.default_rng(1)
        trace: list = [observations]
        for _ in range(25):
            if render:
                env.render()
            actions = {a: int(choose.integers(3)) for a in env.agents}
            trace.append(env.step(actions))
            if render:
                env.render()
        return trace, env.np_random.bit_generator.state

    (plain, plain_rng), (drawn, drawn_rng) = run(False), run(True)
    assert plain_rng == drawn_rng
    for a, b in zip(plain, drawn):
        assert repr(a) == repr(b)


def test_many_agents_fit_in_a_capped_grid():
    sizes = {}
    for n in (8, 20):
        env = flatland_ma.parallel_env("fruits_poisons_multi", render_mode="rgb_array", n_agents=n)
        env.reset(seed=0)
        frame, renderer = draw(env)
        sizes[n] = frame.shape
        assert len(renderer.blocks) == min(n, topdown.MAX_PANELS)
        assert renderer.hidden == max(0, n - topdown.MAX_PANELS)
        assert frame.shape[1] == renderer.map_size[0] and frame.shape[0] < 2.5 * frame.shape[1]
    assert sizes[8][0] < sizes[20][0]


def test_an_agent_without_a_camera_is_drawn():
    blind = {"sensors": [{"type": "lidar"}, {"type": "proprioception"}]}
    env = flatland_ma.parallel_env("fruits_poisons", render_mode="rgb_array", agent=blind)
    env.reset(seed=0)
    frame, renderer = draw(env)
    assert frame.shape[:2] == (renderer.size[1], renderer.size[0])


def test_the_map_shows_agents_in_their_colours():
    env = flatland_ma.parallel_env(
        "fruits_poisons", render_mode="rgb_array", items=[], obstacles=[]
    )
    env.reset(seed=0)
    body = env.running.bodies[0].body
    body.position, body.angle = (150.0, 150.0), 0.0
    env.running.world.space.reindex_shapes_for_body(body)
    frame, r = draw(env)
    # A point of the agent's disc, off the heading line: (150, 145) in world units.
    px = r.map_origin[0] + int((150 + r.margin) * r.scale)
    py = r.map_origin[1] + int((300 - 145 + r.margin) * r.scale)
    colour = np.array(env.running.bodies[0].color) * 255
    np.testing.assert_allclose(frame[py, px], colour, atol=2)


def test_render_without_a_mode_warns_and_draws_nothing():
    env = flatland_ma.parallel_env("fruits_poisons")
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.render() is None


def test_human_mode_opens_a_window_and_closes_it(monkeypatch):
    env = flatland_ma.parallel_env("fruits_poisons", render_mode="human")
    env.reset(seed=0)
    assert env.render() is None
    assert env._renderer is not None and env._renderer._window is not None
    env.close()
    env.close()


def test_human_mode_without_a_display_fails_clearly(monkeypatch):
    """As ``flatland-ma play`` does: no window that nobody can see, no SDL note on stderr,
    but an error saying why and what to do, when the env is made."""
    from flatland_ma.render.display import NoDisplayError

    for name in ("DISPLAY", "WAYLAND_DISPLAY"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("SDL_VIDEODRIVER", "x11")
    monkeypatch.setattr(sys, "platform", "linux")
    with pytest.raises(NoDisplayError, match='no display here.*render_mode="rgb_array"'):
        gymnasium.make("flatland_ma/FruitsPoisons-v0", render_mode="human")
    with pytest.raises(NoDisplayError, match="SDL_VIDEODRIVER=dummy"):
        flatland_ma.parallel_env("fruits_poisons", render_mode="human")
    # A display that goes away after the env was made: the window refuses too.
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = flatland_ma.parallel_env("fruits_poisons", render_mode="human")
    env.reset(seed=0)
    monkeypatch.setenv("SDL_VIDEODRIVER", "x11")
    with pytest.raises(NoDisplayError):
        env.render()
    env.close()


def test_gif_writing(tmp_path):
    env = flatland_ma.parallel_env("fruits_poisons", render_mode="rgb_array")
    env.reset(seed=0)
    frames = [draw(env)[0]]
    for _ in range(3):
        env.step({"agent_0": 0})
        frames.append(draw(env)[0])
    path = save_gif(frames, tmp_path / "out.gif")
    from PIL import Image

    with Image.open(path) as gif:
        assert gif.n_frames == 4 and gif.size == (frames[0].shape[1], frames[0].shape[0])
