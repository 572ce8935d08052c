"""Recordings with the senses panel: GIF and MP4 files written by ``flatland-ma record``
decoded frame by frame, several agents and sensors, and the Gymnasium env's frames for
video wrappers."""

import gymnasium
import numpy as np
from PIL import Image, ImageSequence

import flatland_ma
from flatland_ma.cli import main
from flatland_ma.envs.registration import gym_id
from flatland_ma.render import renderer as topdown
from flatland_ma.render.video import save_mp4


def read_gif(path) -> list[np.ndarray]:
    with Image.open(path) as gif:
        return [np.asarray(frame.convert("RGB")) for frame in ImageSequence.Iterator(gif)]


def read_mp4(path) -> list[np.ndarray]:
    import av

    with av.open(str(path)) as container:
        return [frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)]


def region(frame: np.ndarray, where) -> np.ndarray:
    """The pixels of one sensor's picture."""
    return frame[where.y : where.y + where.slot.height, where.x : where.x + where.slot.width]


def drawn(pixels: np.ndarray) -> bool:
    """Whether a picture shows something: not one flat colour."""
    return float(pixels.astype(float).std(axis=(0, 1)).max()) > 8.0


def layout(scenario: str, **overrides) -> topdown.Renderer:
    env = flatland_ma.parallel_env(scenario, render_mode="rgb_array", **overrides)
    env.reset(seed=0)
    env.render()
    assert env._renderer is not None
    return env._renderer


def test_a_gif_of_several_agents_and_sensors_shows_their_senses(tmp_path):
    out = tmp_path / "senses.gif"
    args = ["record", "fruits_poisons_multi", "--sensors", "camera,lidar,proprioception"]
    assert main([*args, "--steps", "10", "--every", "2", "--out", str(out)]) == 0
    frames = read_gif(out)
    renderer = layout(
        "fruits_poisons_multi",
        agent={"sensors": [{"type": "camera"}, {"type": "lidar"}, {"type": "proprioception"}]},
    )
    assert len(frames) == 6  # the first frame and one in two of 10 steps
    assert {f.shape for f in frames} == {(renderer.size[1], renderer.size[0], 3)}
    assert all(np.abs(a.astype(int) - b).sum() > 0 for a, b in zip(frames, frames[1:]))
    for i in range(4):
        camera, lidar, _ = renderer.placed[i]
        assert drawn(region(frames[-1], camera)) and drawn(region(frames[-1], lidar))
    # The panel changes as the agents move: their cameras see other things.
    first, last = (
        region(frames[0], renderer.placed[0][0]),
        region(frames[-1], renderer.placed[0][0]),
    )
    assert np.abs(first.astype(int) - last).mean() > 1.0


def test_an_mp4_of_more_agents_than_the_scenario_has(tmp_path):
    out = tmp_path / "three.mp4"
    args = ["record", "fruits_poisons", "--agents", "3", "--policy", "random", "--seed", "2"]
    assert main([*args, "--steps", "12", "--every", "3", "--out", str(out)]) == 0
    frames = read_mp4(out)
    renderer = layout("fruits_poisons", n_agents=3)
    width, height = renderer.size
    assert len(frames) == 5
    assert {f.shape for f in frames} == {(height + height % 2, width + width % 2, 3)}
    assert np.abs(frames[0].astype(int) - frames[-1]).mean() > 0.5
    assert len(renderer.blocks) == 3
    for i in range(3):
        (camera,) = renderer.placed[i]
        assert drawn(region(frames[-1], camera))
    assert out.with_suffix(".png").exists()


def test_record_reports_overrides_and_policies_that_cannot_work(tmp_path, capsys):
    out = str(tmp_path / "x.gif")
    assert main(["record", "fruits_poisons", "--sensors", "sonar", "--out", out]) == 2
    assert "sonar" in capsys.readouterr().err
    assert main(["record", "fruits_poisons", "--sensors", "lidar", "--out", out]) == 2
    assert "camera" in capsys.readouterr().err  # the greedy forager reads one
    assert main(["record", "fruits_poisons", "--agents", "0", "--out", out]) == 2
    assert "--agents" in capsys.readouterr().err


def test_the_gym_env_gives_frames_to_video_wrappers(tmp_path):
    env = gymnasium.make(gym_id("fruits_poisons"), render_mode="rgb_array", max_episode_steps=6)
    assert env.metadata["render_fps"] == 30 and env.render_mode == "rgb_array"
    env = gymnasium.wrappers.RenderCollection(env)
    env.reset(seed=0)
    done = False
    while not done:
        *_, terminated, truncated, _ = env.step(0)
        done = terminated or truncated
    rendered = env.render()
    assert isinstance(rendered, list)
    frames = [f for f in rendered if isinstance(f, np.ndarray)]
    assert len(frames) == len(rendered) == 7 and len({f.shape for f in frames}) == 1
    video = read_mp4(save_mp4(frames, tmp_path / "gym.mp4", fps=env.metadata["render_fps"]))
    assert len(video) == 7 and np.abs(video[0].astype(int) - video[-1]).mean() > 0.1


def test_gymnasiums_record_video_writes_an_mp4(tmp_path):
    # RecordVideo writes through moviepy, which the render extra installs.
    env = gymnasium.make(gym_id("fruits_poisons"), render_mode="rgb_array", max_episode_steps=8)
    env = gymnasium.wrappers.RecordVideo(
        env, str(tmp_path / "videos"), episode_trigger=lambda e: True
    )
    env.reset(seed=0)
    done = False
    while not done:
        *_, terminated, truncated, _ = env.step(0)
        done = terminated or truncated
    env.close()
    (video,) = (tmp_path / "videos").glob("*.mp4")
    assert len(read_mp4(video)) >= 8
