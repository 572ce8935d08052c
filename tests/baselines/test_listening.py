"""The channel check (baselines.benchmark.listening): the guides it sets beside a seeker
say what they should (the Signaller the goal's room, the liar another, random words
either), a listening seeker is hurt by the liar, and a checkpoint's pair is checked
end to end."""

from __future__ import annotations

import pytest

torch = pytest.importorskip("torch")

from baselines import ppo  # noqa: E402
from baselines.benchmark import listening  # noqa: E402
from flatland_ma.envs.parallel import FlatlandParallelEnv  # noqa: E402
from flatland_ma.policies.signals import Follower, Signaller  # noqa: E402
from tests.ppo_helpers import tiny_args  # noqa: E402


def test_the_guides_words_and_a_listening_seeker_beside_them():
    env = FlatlandParallelEnv("signal_rooms")
    guide, seeker = listening.roles(env)
    assert (guide, seeker) == ("guide_0", "seeker_0")
    seeds = range(500, 512)
    figures = {}
    for name, make in [
        ("truthful", Signaller),
        ("liar", listening.Liar),
        ("random", listening.RandomWords),
    ]:
        policies = {guide: make(env, guide), seeker: Follower(env, seeker, seed=0)}
        figures[name] = listening.play(env, policies, guide, seeds)
    env.close()
    assert figures["truthful"][1:] == (1.0, 1.0) and figures["liar"][1:] == (0.0, 0.0)
    assert 0.0 < figures["random"][1] < 1.0 and 0.3 < figures["random"][2] < 0.7
    # the scripted follower goes where it is told: the liar sends it to the wrong room
    assert figures["truthful"][0] > figures["random"][0] > figures["liar"][0]


def test_a_checkpoints_pair_is_checked_beside_every_guide(tmp_path):
    ppo.main(tiny_args(tmp_path, scenario="signal_rooms", hidden=16))
    figures = listening.check(str(tmp_path / "seed_0.safetensors"), episodes=2)
    assert list(figures) == [
        "its own guide",
        "Signaller",
        "random words",
        "liar",
        "its own guide, the Heeder seeking",
    ]
    assert figures["Signaller"][1:] == (1.0, 1.0) and figures["liar"][1:] == (0.0, 0.0)
    # the same guide, beside the checkpoint's seeker and beside the Heeder, says the same
    assert figures["its own guide"][1] == figures["its own guide, the Heeder seeking"][1]


def test_a_task_without_a_guide_and_a_seeker_is_refused():
    env = FlatlandParallelEnv("fruits_poisons")
    with pytest.raises(ValueError, match="guide"):
        listening.roles(env)
    env.close()
