"""The batched PPO's network: encoders chosen by each observation entry's shape, one
categorical head per component of a MultiDiscrete action, log-probabilities and entropies
summed over the heads."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces

torch = pytest.importorskip("torch")

from baselines.networks import Agent, FlatInput, ImageInput, MapInput  # noqa: E402

CAMERA = spaces.Box(0.0, 1.0, (64, 4), np.float32)
HEARD = spaces.Box(0.0, 1.0, (2, 3), np.float32)
MAP = spaces.Box(0.0, 1.0, (48, 48, 3), np.float32)


def _sample(space: spaces.Space, n: int):
    space.seed(0)
    samples = [space.sample() for _ in range(n)]
    if isinstance(space, spaces.Dict):
        return {k: torch.as_tensor(np.stack([s[k] for s in samples])) for k in space.spaces}
    return torch.as_tensor(np.stack(samples))


def test_each_entry_gets_the_encoder_of_its_shape():
    agent = Agent(spaces.Dict(camera=CAMERA, messages=HEARD, topdown=MAP), spaces.Discrete(3))
    kinds = {key: type(module) for key, module in agent.inputs.items()}
    assert kinds == {"camera": ImageInput, "messages": FlatInput, "topdown": MapInput}
    assert agent.inputs["messages"].features == 6
    assert agent.inputs["camera"].channels == 3  # colour only unless depth is asked for


def test_a_multidiscrete_action_is_independent_heads_whose_log_probabilities_add():
    space = spaces.Dict(messages=HEARD, topdown=MAP)
    agent = Agent(space, spaces.MultiDiscrete([3, 2, 4]), hidden=32)
    x = _sample(space, 5)
    logits = agent(x)
    assert logits.shape == (5, 9)
    action, logprob, entropy, value = agent.act(x)
    assert action.shape == (5, 3) and value.shape == (5,)
    assert (action < torch.tensor([3, 2, 4])).all() and (action >= 0).all()
    want_logprob = torch.zeros(5)
    want_entropy = torch.zeros(5)
    for part, k in zip(logits.split([3, 2, 4], dim=1), range(3)):
        p = part.softmax(dim=1)
        want_logprob += p.gather(1, action[:, k : k + 1]).squeeze(1).log()
        want_entropy += -(p * p.log()).sum(dim=1)
    assert torch.allclose(logprob, want_logprob, atol=1e-6)
    assert torch.allclose(entropy, want_entropy, atol=1e-6)
    # Evaluating a given action gives the same numbers as sampling it.
    _, again, _, _ = agent.act(x, action)
    assert torch.allclose(again, logprob)


def test_a_discrete_action_space_has_one_head_and_a_box_observation_one_input():
    agent = Agent(CAMERA, spaces.Discrete(3), hidden=16)
    action, logprob, entropy, _ = agent.act(_sample(CAMERA, 4))
    assert action.shape == (4, 1)
    assert torch.all(entropy <= np.log(3) + 1e-6) and torch.all(logprob <= 0)


def test_spaces_ppo_cannot_act_in_are_refused_by_name():
    with pytest.raises(ValueError, match="Discrete or MultiDiscrete"):
        Agent(CAMERA, spaces.Box(-1.0, 1.0, (2,), np.float32))
    with pytest.raises(ValueError, match="too small"):
        Agent(spaces.Box(0.0, 1.0, (6, 6, 3), np.float32), spaces.Discrete(3))


@pytest.mark.parametrize("network", ["strided", "paper"])
@pytest.mark.parametrize("batch", [1, 16, 300])
def test_the_acting_pass_convolves_as_training_does(network, batch):
    """Without gradients the image trunk convolves by one matrix product over windows
    (faster at acting batches); it must give what the training path's Conv1d gives."""
    from flatland_ma.policies.networks import ImageInput

    torch.manual_seed(batch)
    encoder = ImageInput((64, 4), 3, network)
    x = torch.rand(batch, 64, 4)
    trained = encoder(x)
    with torch.no_grad():
        acted = encoder(x)
    assert acted.shape == trained.shape
    torch.testing.assert_close(acted, trained.detach(), rtol=1e-5, atol=1e-5)
    assert trained.abs().max() > 0.01
