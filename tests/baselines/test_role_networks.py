"""A network for each role (``--role-networks``, ``PPONetwork(roles=R)``): a row's
action and value come from its own role's part alone, its gradients reach no other
role's, a stage that trains one role leaves the other's part as it was, and the options
it cannot serve are refused."""

from __future__ import annotations

from pathlib import Path

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

from baselines import ppo  # noqa: E402
from flatland_ma.policies.networks import PPONetwork  # noqa: E402
from flatland_ma.policies.roles import RoleBody, RoleStack  # noqa: E402
from tests.ppo_helpers import tiny_args  # noqa: E402


def _args(folder: Path, **options) -> ppo.Args:
    base = {"scenario": "signal_rooms", "num_envs": 2, "num_steps": 16, "hidden": 16}
    return tiny_args(folder, **{**base, "role_networks": True, **options})


def _part(network: PPONetwork, role: int) -> dict:
    """The parameters of one role's part: its encoders and layer, and its columns of the
    heads (its block of features and its bias column)."""
    out = {}
    for key, module in network.inputs.items():
        if isinstance(module, RoleStack):
            for name, p in module.encoders[role].named_parameters():
                out[f"inputs.{key}.{name}"] = p
    body = network.body
    assert isinstance(body, RoleBody)
    for name, p in body.layers[role].named_parameters():
        out[f"body.{name}"] = p
    hidden = network.hidden
    for head in ("actor", "critic"):
        weight = getattr(network, head).weight
        out[f"{head}.block"] = weight[:, role * hidden : (role + 1) * hidden]
        out[f"{head}.bias"] = weight[:, body.roles * hidden + role]
    return out


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A run's network and one rollout's observations, with each row's role."""
    training = ppo.Training(_args(tmp_path_factory.mktemp("roles")))
    try:
        rollout = training.rollout
        rollout.collect(training.agent, training.env, training.observation, 0.1, lambda *a: None)
        x = {k: v.flatten(0, 1) for k, v in rollout.observations.items()}
        yield training.agent, x, x["role"].argmax(-1)
    finally:
        training.env.close()


def test_a_rows_action_and_value_depend_on_its_own_roles_part_alone(run):
    agent, x, role = run
    assert agent.roles == 2 and set(role.tolist()) == {0, 1}
    with torch.no_grad():
        before = agent.actor(agent.features(x)), agent.value(x)
        for p in _part(agent, 1).values():
            p.add_(torch.randn_like(p))
        after = agent.actor(agent.features(x)), agent.value(x)
    for old, new in zip(before, after):
        assert torch.equal(old[role == 0], new[role == 0])  # role 0's rows: as they were
        assert not torch.allclose(old[role == 1], new[role == 1])


def test_gradients_of_one_roles_rows_reach_only_its_part(run):
    agent, x, role = run
    agent.zero_grad()
    _, logprob, entropy, value = agent.act(x)
    rows = role == 0
    (logprob[rows].sum() + entropy[rows].sum() + value[rows].square().sum()).backward()

    def grad(name: str, p, of: int):
        if name.split(".")[0] in ("actor", "critic"):
            return _head_grad(agent, name, of)
        return torch.zeros_like(p) if p.grad is None else p.grad

    assert all(not grad(n, p, 1).any() for n, p in _part(agent, 1).items())
    # role 0's layer and heads learn from its rows (its encoders of an entry it never
    # observes, all zeros for it, learn only their biases)
    own = {n: grad(n, p, 0) for n, p in _part(agent, 0).items()}
    assert all(g.any() for n, g in own.items() if not n.startswith("inputs."))
    agent.zero_grad()


def _head_grad(agent: PPONetwork, name: str, role: int):
    head, which = name.split(".")
    grad = getattr(agent, head).weight.grad
    hidden, roles = agent.hidden, agent.roles
    if which == "block":
        return grad[:, role * hidden : (role + 1) * hidden]
    return grad[:, roles * hidden + role]


def test_a_stage_that_trains_one_role_leaves_the_others_part_as_it_was(tmp_path):
    curriculum = tmp_path / "guide_alone.yaml"
    curriculum.write_text(
        "tasks:\n"
        "  - {name: told, scenario: signal_rooms, focal: [guide], background: heeder,"
        " steps: 96}\n"
    )
    args = _args(tmp_path / "run", curriculum=str(curriculum))
    training = ppo.Training(args)
    try:
        seeker = training.env.spec.agent_names.index("seeker_0")
        padding = training.env.padding
        assert padding is not None
        role = padding.role_of[seeker]
        start = {k: p.detach().clone() for k, p in _part(training.agent, role).items()}
        guide = {k: p.detach().clone() for k, p in _part(training.agent, 1 - role).items()}
        for iteration in range(1, training.iterations + 1):
            training.iterate(iteration, 0.0)
        now = _part(training.agent, role)
        assert all(torch.equal(start[k], now[k]) for k in start)
        moved = _part(training.agent, 1 - role)
        assert any(not torch.equal(guide[k], moved[k]) for k in guide)
    finally:
        training.env.close()


def test_options_a_network_for_each_role_cannot_serve_are_refused(tmp_path):
    with pytest.raises(ValueError, match="observes alike"):
        ppo.Training(_args(tmp_path / "one", scenario="fruits_poisons"))
    with pytest.raises(ValueError, match="feed-forward"):
        ppo.Training(_args(tmp_path / "gru", memory="gru"))
    with pytest.raises(ValueError, match="'role' entry has 3 values"):
        PPONetwork({"role": (2,), "observation": (8,)}, (3,), roles=3)
    with pytest.raises(ValueError, match="at least 2 roles"):
        PPONetwork({"role": (1,), "observation": (8,)}, (3,), roles=1)


def test_a_run_with_a_network_for_each_role_trains_and_says_so(tmp_path):
    summary = ppo.main(_args(tmp_path / "whole"))
    assert summary["args"]["role_networks"] is True
