"""The exploration bonus of ``baselines.ppo --novelty`` (random network distillation,
``baselines.novelty``): running moments against numpy's, the bonus high on what is new and
low on what was seen, measured on what each step returned and 0 where the env did not use
the action, added to the rewards PPO learns from, kept and restored with a run's
checkpoints, and bad weights refused."""

from __future__ import annotations

import copy
import math
from dataclasses import replace

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

from baselines import ppo  # noqa: E402
from baselines.novelty import Moments, Novelty  # noqa: E402
from baselines.ppo_learner import Rollout  # noqa: E402
from flatland_ma.policies.checkpoint import CheckpointPolicy, load_checkpoint  # noqa: E402

STEPS = 32


def test_moments_over_batches_are_those_of_all_the_rows_at_once():
    rng = np.random.default_rng(0)
    batches = [rng.normal(3.0, 2.0, size=(n, 4)) for n in (1, 7, 50, 3)]
    moments = Moments(4)
    for rows in batches:
        moments.update(rows)
    moments.update(np.zeros((0, 4)))  # an empty batch changes nothing
    every = np.concatenate(batches)
    assert np.allclose(moments.mean, every.mean(0), atol=1e-5)
    assert np.allclose(moments.var, every.var(0), atol=1e-4)


def _rollout(rows: np.ndarray, acting=None):
    """A rollout's observations (T, slots, F) from ``rows`` (T + 1, slots, F): steps
    0..T-1 as seen, the last row as what the last step returned."""
    observations = torch.from_numpy(rows[:-1].astype(np.float32))
    acting = torch.ones(rows.shape[:2], dtype=torch.bool)[:-1] if acting is None else acting
    return observations, rows[-1].astype(np.float32), acting


def test_the_bonus_falls_on_what_is_seen_again_and_stays_high_on_what_is_new():
    rng = np.random.default_rng(1)
    seen = rng.normal(size=(1, 1, 16)).repeat(33, axis=0).repeat(4, axis=1)
    seen += rng.normal(scale=0.05, size=seen.shape)
    novelty = Novelty(seen[0], slots=4, weight=1.0, seed=0)
    first = novelty.bonus(*_rollout(seen))
    for _ in range(30):
        last = novelty.bonus(*_rollout(seen))
    assert float(last.mean()) < 0.2 * float(first.mean())
    # Observations far from every one the predictor trained on: a larger bonus.
    new = rng.normal(loc=3.0, size=seen.shape)
    novelty.train = lambda x: 0.0  # measure without training on them
    assert float(novelty.bonus(*_rollout(new)).mean()) > 5 * float(last.mean())
    assert novelty.stats["novelty/bonus"] > 0


def test_the_bonus_is_of_what_each_step_returned_and_zero_where_no_action_was_used():
    rng = np.random.default_rng(2)
    rows = rng.normal(size=(5, 3, 6))
    novelty = Novelty(rows[0], slots=3, weight=2.0, seed=0)
    observations, final, _ = _rollout(rows)
    following = novelty.inputs_of(observations, final)
    assert torch.equal(following, torch.from_numpy(rows[1:].astype(np.float32)))
    acting = torch.ones((4, 3), dtype=torch.bool)
    acting[1, 2] = acting[3, 0] = False
    bonus = novelty.bonus(observations, final, acting)
    assert bonus.shape == (4, 3)
    assert bonus[1, 2] == 0 and bonus[3, 0] == 0 and bool((bonus[acting] > 0).all())


def test_a_dict_observation_is_read_leaf_by_leaf_uint8_maps_as_numbers():
    image = np.arange(2 * 3 * 4, dtype=np.uint8).reshape(2, 3, 4)
    sample = {"image": image, "heard": np.ones((2, 5), np.float32)}
    novelty = Novelty(sample, slots=2, weight=1.0, seed=0)
    assert novelty.features == 3 * 4 + 5
    observations = {k: torch.from_numpy(np.stack([v, v])) for k, v in sample.items()}
    x = novelty.inputs_of(observations, sample)
    assert x.shape == (2, 2, 17) and x.dtype == torch.float32
    assert torch.equal(x[0, 1, :12], torch.arange(12, 24, dtype=torch.float32))


def test_making_the_bonus_leaves_the_runs_own_random_draws_as_they_were():
    torch.manual_seed(5)
    expected = torch.rand(3)
    torch.manual_seed(5)
    Novelty(np.zeros((2, 8), np.float32), slots=2, weight=1.0, seed=9)
    assert torch.equal(torch.rand(3), expected)
    # The same seed: the same target network.
    a, b = (Novelty(np.zeros((2, 8)), slots=2, weight=1.0, seed=9) for _ in range(2))
    assert all(torch.equal(x, y) for x, y in zip(a.target.parameters(), b.target.parameters()))


@pytest.mark.parametrize("weight", [-0.5, 0.0, math.nan, math.inf, "1"])
def test_a_weight_that_is_no_positive_number_is_refused_naming_the_option(weight):
    with pytest.raises(ValueError, match="--novelty"):
        Novelty(np.zeros((1, 4)), slots=1, weight=weight, seed=0)  # type: ignore[arg-type]


def _args(tmp_path, **options) -> ppo.Args:
    base = ppo.Args(
        scenario="fruits_poisons",
        num_envs=2,
        num_steps=STEPS,
        total_timesteps=4 * 2 * STEPS,
        checkpoint_every=2,
        tensorboard=False,
        novelty=0.5,
        csv=str(tmp_path / "seed_0.csv"),
    )
    return replace(base, **options)


def test_ppo_learns_from_the_reward_and_the_bonus_added(monkeypatch, tmp_path):
    """The advantages of a rollout with the bonus are GAE's over the reward plus it."""
    seen = {}
    advantages = Rollout.advantages

    def spy(self, args):
        if self.novelty is not None and "with" not in seen:
            novelty, state = self.novelty, copy.deepcopy(self.novelty.state())
            result = advantages(self, args)
            bonus = novelty.bonus  # the bonus measured again by the same predictor
            novelty.load(state)
            self.novelty, rewards = None, self.rewards.clone()
            self.rewards += bonus(self.observations, self.final, self.acting)
            seen["with"], seen["by hand"] = result, advantages(self, args)
            self.rewards[:], self.novelty = rewards, novelty
            return result
        return advantages(self, args)

    monkeypatch.setattr(Rollout, "advantages", spy)
    summary = ppo.main(_args(tmp_path))
    assert summary["steps"] == 4 * 2 * STEPS
    assert torch.allclose(seen["with"], seen["by hand"], atol=1e-6)


def test_the_bonus_goes_on_from_a_checkpoint_and_the_policy_plays_as_any(tmp_path):
    ppo.main(_args(tmp_path))
    checkpoint = tmp_path / "seed_0" / "update_00002.safetensors"
    _, _, state = load_checkpoint(checkpoint)
    saved = state["optimizer"]["novelty"]
    args = replace(_args(tmp_path), resume=True)
    for path in sorted((tmp_path / "seed_0").glob("update_0000[34]*")):
        path.unlink()  # go on from update 2
    run = ppo.Training(args)
    assert run.resumed is not None and run.resumed.path == checkpoint
    kept = run.novelty.state()
    assert all(torch.equal(kept["predictor"][k], v) for k, v in saved["predictor"].items())
    assert np.array_equal(run.novelty.inputs.mean, saved["inputs"]["mean"].numpy())
    assert np.array_equal(run.novelty.running, saved["running"].numpy())
    run.env.close()
    # A checkpoint of a run with the bonus plays as any other (the bonus is the run's).
    policy = CheckpointPolicy(tmp_path / "seed_0.safetensors", seed=0)
    assert policy.scenario == "fruits_poisons"
    # Without the bonus's state, a run with --novelty does not go on from it.
    ppo.main(_args(tmp_path / "plain", novelty=0.0))
    with pytest.raises(ValueError, match="other arguments: novelty 0.0"):
        ppo.main(replace(_args(tmp_path / "plain"), resume=True))
