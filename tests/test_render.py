"""Pictures: the top-down view and each agent's 1-D image drawn as strips."""

import numpy as np
import pytest

import flatland_ma
from flatland_ma.render import topdown
from flatland_ma.render.video import save_gif


def test_frames_have_a_fixed_size_and_show_each_agents_strips():
    env = flatland_ma.parallel_env("fruits_poisons_multi", render_mode="rgb_array")
    env.reset(seed=2)
    frame = env.render()
    renderer = env._renderer
    assert frame.dtype == np.uint8 and frame.shape == (renderer.size[1], renderer.size[0], 3)
    for _ in range(10):
        env.step({a: 0 for a in env.agents})
    assert env.render().shape == frame.shape
    sensors = env.episode.sensors
    width = renderer.size[0]
    for i in range(4):
        top = renderer.map_size[1] + i * renderer.strip_block + topdown.LABEL_HEIGHT
        strip = env.render()[top + topdown.STRIP_HEIGHT // 2]
        image = sensors.image[sensors.slices[i]]
        n = len(image)
        centres = ((np.arange(n) + 0.5) * width / n).astype(int)
        expected = np.clip(image[:, :3], 0, 1) * 255
        np.testing.assert_allclose(strip[centres], expected, atol=1.0)


def test_the_map_shows_agents_in_their_colours():
    env = flatland_ma.parallel_env(
        "fruits_poisons", render_mode="rgb_array", items=[], obstacles=[]
    )
    env.reset(seed=0)
    body = env.episode.bodies[0].body
    body.position, body.angle = (150.0, 150.0), 0.0
    env.episode.world.space.reindex_shapes_for_body(body)
    frame = env.render()
    r = env._renderer
    # A point of the agent's disc, off the heading line: (150, 145) in world units.
    px = int((150 + r.margin) * r.scale)
    py = int((300 - 145 + r.margin) * r.scale)
    colour = np.array(env.episode.bodies[0].color) * 255
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
    assert env._renderer._window is not None
    env.close()
    env.close()


def test_gif_writing(tmp_path):
    env = flatland_ma.parallel_env("fruits_poisons", render_mode="rgb_array")
    env.reset(seed=0)
    frames = [env.render()]
    for _ in range(3):
        env.step({"agent_0": 0})
        frames.append(env.render())
    path = save_gif(frames, tmp_path / "out.gif")
    from PIL import Image

    with Image.open(path) as gif:
        assert gif.n_frames == 4 and gif.size == (frames[0].shape[1], frames[0].shape[0])
