"""A trained network saved by the baselines, played as a policy.

A checkpoint is one safetensors file (``.safetensors``) that holds only data:

- the network's weights, as tensors named ``model/<parameter>`` (its ``state_dict``);
- a JSON description in the file's metadata (``policies.checkpoint_spec``): the format
  version, the scenario, the spaces, and the network as a ``kind`` with its constructor
  arguments, which this package's own code (``policies.networks``) rebuilds;
- optionally the trainer's state for resuming: the optimiser's state as JSON in the
  description (``optimizer``) with its tensors named ``optimizer/...``, and the training
  arguments, update and step counts. ``read_trainer_state`` gives the model's and the
  optimiser's state dicts back.

Loading never unpickles and never runs code from the file: the file must be a regular
file of at most 256 MiB, its header strict JSON of at most 1 MiB, every tensor the
described network needs present with its shape, as float32 and finite (NaN or infinite
weights are refused), and nothing else. Each fault is a ``ValueError`` naming the file
and the entry. A checkpoint of the old format (a ``torch.save`` archive, which could run
code) is refused with the command that converts a file you trust
(``flatland-ma checkpoint convert OLD NEW``). ``write_checkpoint`` (used by the baselines)
writes one; ``CheckpointPolicy`` plays one, without the training code::

    policy = CheckpointPolicy("runs/ppo/fruits_poisons/seed_0.safetensors")
    action = policy.act(observation)

torch and safetensors are needed (the ``train`` extra); they are imported only when a
checkpoint is used.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from flatland_ma.policies.checkpoint_spec import (
    FORMAT,
    METADATA_KEY,
    VERSION,
    check_description,
    space_description,
)
from flatland_ma.policies.tensor_file import (
    decode_tree,
    encode_tree,
    read_tensor_file,
    strict_json,
    write_tensor_file,
)

SUFFIX = ".safetensors"
MODEL, OPTIMIZER = "model/", "optimizer"
"""The names of the network's tensors begin with MODEL; the optimiser's with OPTIMIZER."""
__all__ = ["FORMAT", "VERSION", "CheckpointPolicy", "read_checkpoint", "write_checkpoint"]


def write_checkpoint(
    path: str | Path,
    network: Any,
    *,
    scenario: str,
    observation_space: Any,
    action_space: Any,
    optimizer: dict | None = None,
    extra: dict | None = None,
) -> Path:
    """Save ``network`` (a ``policies.networks`` network: it has ``kind`` and
    ``arguments()``) for these spaces, the optimiser's ``state_dict()`` if given, and
    ``extra`` entries of the description (``algorithm``, ``args``, ``trained_with``, ...:
    JSON). The description is checked as a reader will check it, and the network rebuilt
    from it must have the same tensors. Written to a temporary file and moved into place."""
    from flatland_ma.policies.networks import build_network

    path = Path(path)
    description = {
        "format": FORMAT,
        "version": VERSION,
        "scenario": scenario,
        "observation_space": str(observation_space),
        "action_space": str(action_space),
        "spaces": {
            "observation": space_description(observation_space),
            "action": space_description(action_space),
        },
        "action_sizes": _action_sizes(action_space),
        "network": {"kind": network.kind, "arguments": network.arguments()},
        **(extra or {}),
    }
    tensors = {MODEL + name: t for name, t in network.state_dict().items()}
    if optimizer is not None:
        description["optimizer"] = encode_tree(optimizer, OPTIMIZER, tensors)
    text = json.dumps(description, allow_nan=False)
    info = check_description(path, json.loads(text))
    rebuilt = build_network(info["network"]["kind"], info["spaces"], info["network"]["arguments"])
    want = {name: tuple(t.shape) for name, t in rebuilt.state_dict().items()}
    have = {name: tuple(t.shape) for name, t in network.state_dict().items()}
    if want != have:
        raise ValueError(f"{path}: the network's tensors are not those its description builds")
    path.parent.mkdir(parents=True, exist_ok=True)
    write_tensor_file(path, tensors, {METADATA_KEY: text})
    return path


def _action_sizes(space: Any) -> list[int]:
    """The number of choices of each component of a ``Discrete`` (one) or
    ``MultiDiscrete`` action space."""
    nvec = getattr(space, "nvec", None)
    return [int(space.n)] if nvec is None else [int(n) for n in np.asarray(nvec).ravel()]


def _description(path: Path, metadata: dict[str, str]) -> dict:
    if METADATA_KEY not in metadata:
        raise ValueError(f"{path}: not a flatland_ma policy checkpoint (no {METADATA_KEY!r})")
    try:
        data = strict_json(metadata[METADATA_KEY])
    except (ValueError, RecursionError) as err:
        raise ValueError(f"{path}: its description is not JSON ({err})") from None
    return check_description(path, data)


def _needs_torch(path: str | Path) -> None:
    try:
        import safetensors  # noqa: F401
        import torch  # noqa: F401
    except ImportError as err:
        raise ValueError(
            f"{path}: playing a checkpoint needs torch and safetensors "
            "(pip install torch safetensors; or, in a clone of flatland_ma, its train extra: "
            "pip install -e '.[train]')"
        ) from err


def read_checkpoint(path: str | Path) -> dict:
    """The checkpoint's description (a dict; its tensors are not read), checked; errors
    name the file and the entry."""
    _needs_torch(path)
    return read_tensor_file(path, tensors=False, check=lambda m: _description(Path(path), m))[0]


def load_checkpoint(path: str | Path) -> tuple[dict, Any, dict]:
    """The description, the network rebuilt with the file's weights (in eval mode, no
    gradients) and the trainer's state (``read_trainer_state``), each checked."""
    _needs_torch(path)
    from flatland_ma.policies.networks import build_network

    path = Path(path)
    info, tensors = read_tensor_file(path, check=lambda m: _description(path, m))
    kind, arguments = info["network"]["kind"], info["network"]["arguments"]
    try:
        network = build_network(kind, info["spaces"], arguments)
    except (ValueError, RuntimeError) as err:
        raise ValueError(
            f"{path}: network: the spaces and arguments make no {kind} ({err})"
        ) from None
    weights = _weights(path, tensors, network.state_dict())
    network.load_state_dict(weights, strict=True, assign=True)
    network.eval().requires_grad_(False)
    _probe(path, info, network)
    optimizer = None
    if info["optimizer"] is not None:
        optimizer = decode_tree(info["optimizer"], tensors, f"{path}: optimizer")
    stray = set(tensors) - {MODEL + name for name in weights} - _named(info["optimizer"])
    if stray:
        raise ValueError(f"{path}: tensor {sorted(stray)[0]!r}: not part of the checkpoint")
    return info, network, {"model": weights, "optimizer": optimizer}


def _weights(path: Path, tensors: dict, want: dict) -> dict:
    """The network's tensors from the file's, each checked against the rebuilt network's."""
    import torch

    weights = {}
    for name, like in want.items():
        where = f"{path}: tensor {MODEL + name!r}"
        tensor = tensors.get(MODEL + name)
        if tensor is None:
            raise ValueError(f"{where}: missing (the described network needs it)")
        if tuple(tensor.shape) != tuple(like.shape):
            raise ValueError(
                f"{where}: shape {list(tensor.shape)}, the described network needs "
                f"{list(like.shape)}"
            )
        if tensor.dtype != torch.float32:
            raise ValueError(f"{where}: dtype {tensor.dtype}, the network needs float32")
        if not bool(torch.isfinite(tensor).all()):
            raise ValueError(f"{where}: holds NaN or infinite weights")
        weights[name] = tensor
    return weights


def _named(code: Any) -> set[str]:
    """The tensor names a JSON tree from ``encode_tree`` refers to."""
    if isinstance(code, list):
        return set().union(*map(_named, code)) if code else set()
    if isinstance(code, dict):
        if set(code) == {"tensor"} and isinstance(code["tensor"], str):
            return {code["tensor"]}
        return set().union(*map(_named, code.values())) if code else set()
    return set()


def _probe(path: Path, info: dict, network: Any) -> None:
    """One batch of zeros through the network: its logits must fit the action space."""
    import torch

    observation = info["spaces"]["observation"]
    if observation["type"] == "Box":
        zeros: Any = torch.zeros((1, *observation["shape"]))
    else:
        zeros = {k: torch.zeros((1, *s["shape"])) for k, s in observation["spaces"].items()}
    try:
        with torch.inference_mode():
            logits = network.logits(zeros)
    except RuntimeError as err:
        raise ValueError(f"{path}: network: it cannot read its observation space ({err})") from None
    want = (1, sum(info["action_sizes"]))
    if tuple(logits.shape) != want:
        raise ValueError(
            f"{path}: network: logits of shape {list(logits.shape)[1:]}, the action space "
            f"needs {want[1]}"
        )


def agent_spaces(description: dict, env, agent: str) -> tuple[Any, Any, Any]:
    """The observation and action spaces a checkpoint described by ``description`` must
    have been trained in to play ``agent`` of ``env``, and the env's ``Padding`` when the
    network read padded observations (None otherwise)."""
    observation_space = env.observation_space(agent)
    padding = None
    if description.get("padded"):
        from flatland_ma.envs.padding import Padding

        padding = Padding.of(env)
        if padding is not None:
            observation_space = padding.space
    return observation_space, env.action_space(agent), padding


def check_spaces(path: str | Path, description: dict, observation_space, action_space) -> None:
    """``ValueError`` naming ``path`` unless the checked ``description`` (its spaces as
    text and as JSON) is of these spaces."""
    for what, space in (("observation", observation_space), ("action", action_space)):
        saved = description[f"{what}_space"]
        if str(space) != saved or space_description(space) != description["spaces"][what]:
            raise ValueError(f"{path}: trained for the {what} space {saved}, the agent has {space}")


def read_trainer_state(path: str | Path) -> dict:
    """``{"model": state_dict, "optimizer": state_dict or None}`` for resuming training,
    checked as ``load_checkpoint`` checks them."""
    return load_checkpoint(path)[2]


class CheckpointPolicy:
    """Plays a saved network: samples from its action distribution with its own seeded
    generator, or takes the most likely action when ``greedy``.

    A network with memory (a recurrent core, or ``frames`` > 1) remembers the agent's
    episode between calls of ``act``; ``reset()`` (which the runners call at every
    reset, and ``bind``) makes it forget. ``logits`` and ``act_batch`` read each row as
    an episode's first step."""

    def __init__(self, path: str | Path, greedy: bool = False, seed: int | None = None):
        self.path = Path(path)
        self.data, self.network, _ = load_checkpoint(path)
        self.scenario: str = self.data["scenario"]
        self.greedy = greedy
        self.rng = np.random.default_rng(seed)
        self._padding: tuple | None = None
        """The padding of the agent played (see ``bind``), or None."""
        self._memory: Any = None
        """What the network remembers of the agent's episode so far (None: nothing)."""

    def reset(self) -> None:
        """Forget the episode: the next ``act`` is an episode's first step."""
        self._memory = None

    @staticmethod
    def for_agent(
        path: str | Path, env, agent: str, greedy: bool = False, seed: int | None = None
    ) -> CheckpointPolicy:
        """The checkpoint ``path`` playing ``agent`` of ``env``: its description's spaces
        are checked against the agent's (``check_spaces``) before any tensor is read or
        made, then it is loaded and bound."""
        description = read_checkpoint(path)
        observation_space, action_space, _ = agent_spaces(description, env, agent)
        check_spaces(path, description, observation_space, action_space)
        policy = CheckpointPolicy(path, greedy, seed)
        policy.bind(env, agent)
        return policy

    def check(self, observation_space, action_space) -> None:
        """Raise ``ValueError`` unless the agent's spaces are those the network learnt on."""
        check_spaces(self.path, self.data, observation_space, action_space)

    def bind(self, env, agent: str) -> None:
        """Play ``agent`` of ``env``: check its spaces against the network's. A network
        trained on padded observations (agents of several roles, ``pad=True``) reads this
        agent's observation padded as in training, its role named."""
        self.reset()
        observation_space, action_space, padding = agent_spaces(self.data, env, agent)
        self.check(observation_space, action_space)
        if padding is not None:
            self._padding = (padding, env.possible_agents.index(agent))

    def act(self, observation):
        """One agent's action: an int, or an array for a ``MultiDiscrete`` space."""
        if self._padding is not None:
            padding, index = self._padding
            observation = padding.pad(index, observation)
        if isinstance(observation, dict):
            batch = {key: np.asarray(value)[None] for key, value in observation.items()}
        else:
            batch = np.asarray(observation)[None]
        if getattr(self.network, "remembers", False):
            action = self._actions(self.step_logits(batch))[0]
        else:
            action = self.act_batch(batch)[0]
        return int(action) if np.ndim(action) == 0 else action

    def step_logits(self, observations) -> np.ndarray:
        """The logits (as ``logits``) of the next step of the agents whose memory this
        policy keeps (one: ``act``'s agent), from a batch of their observations; their
        memory moves on by the step (without memory: ``logits``)."""
        import torch

        with torch.inference_mode():
            h, self._memory = self.network.step(_tensors(observations), self._memory)
            return self.network.actor(h).double().numpy()

    def logits(self, observations) -> np.ndarray:
        """The network's logits for a batch of raw observations (every action component's,
        joined), as float64; each row as an episode's first step."""
        import torch

        with torch.inference_mode():
            return self.network.logits(_tensors(observations)).double().numpy()

    def act_batch(self, observations) -> np.ndarray:
        """One action per row of ``observations`` (an array, or a dict of arrays for a
        ``Dict`` space): shape (batch,) for a ``Discrete`` space, (batch, components) for
        a ``MultiDiscrete`` one."""
        return self._actions(self.logits(observations))

    def _actions(self, logits: np.ndarray) -> np.ndarray:
        sizes = self.data["action_sizes"]
        parts = np.split(logits, np.cumsum(sizes)[:-1], axis=1)
        actions = np.stack([self._choose(part) for part in parts], axis=1)
        multi = self.data["spaces"]["action"]["type"] == "MultiDiscrete"
        return actions if multi else actions[:, 0]

    def _choose(self, logits: np.ndarray) -> np.ndarray:
        if self.greedy:
            return logits.argmax(axis=1)
        p = np.exp(logits - logits.max(axis=1, keepdims=True))
        cumulative = (p / p.sum(axis=1, keepdims=True)).cumsum(axis=1)
        draws = self.rng.random((len(p), 1))
        return np.minimum((cumulative < draws).sum(axis=1), p.shape[1] - 1)


def _tensors(observations):
    """A batch of raw observations (an array, or a dict of arrays) as float32 tensors."""
    import torch

    if isinstance(observations, dict):
        return {k: torch.as_tensor(v, dtype=torch.float32) for k, v in observations.items()}
    return torch.as_tensor(observations, dtype=torch.float32)
