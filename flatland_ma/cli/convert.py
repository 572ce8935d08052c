"""``flatland-ma checkpoint``: convert a checkpoint of the old format, or show one.

``convert OLD NEW`` is the one explicit, trusted path from the old format (version 1: a
``torch.save`` archive holding a ``torch.export`` program, which can run code when it is
loaded) to the data-only one. It reads OLD with ``torch.load(weights_only=True)`` and
takes from it only the trained network's state dict (``model``), the optimiser's state and
the plain entries (scenario, spaces, arguments); the exported program is never loaded.
The network is rebuilt by this package's own code from the training arguments and the
spaces of the scenario's agents, the weights must fit it exactly, and NEW is written as a
safetensors checkpoint. Convert only files whose source you trust: ``weights_only``
narrows what unpickling can do but is still unpickling.

``show FILE`` prints a checkpoint's description (JSON) without reading its tensors.
"""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path
from typing import Any

from flatland_ma.policies.checkpoint import SUFFIX, read_checkpoint, write_checkpoint
from flatland_ma.policies.checkpoint_spec import FORMAT, space_description
from flatland_ma.policies.tensor_file import read_regular_file, written_by_torch_save

KEPT = ("padded", "trained_with", "overrides", "algorithm", "args", "update", "agent_steps")
"""The old checkpoint's plain entries that the new one keeps as they are."""


def add_parser(commands) -> None:
    checkpoint = commands.add_parser(
        "checkpoint",
        help="convert an old (torch.save) checkpoint you trust, or show one's description",
        description=__doc__.split("\n\n")[1].replace("``", "") if __doc__ else None,
    )
    what = checkpoint.add_subparsers(dest="checkpoint", required=True, metavar="WHAT")
    convert = what.add_parser("convert", help="OLD (a .pt of the old format) -> NEW")
    convert.add_argument("old", metavar="OLD", help="the old checkpoint, from a source you trust")
    convert.add_argument("new", metavar="NEW", help=f"the new checkpoint, a {SUFFIX} file")
    convert.add_argument("--force", action="store_true", help="replace NEW if it exists")
    show = what.add_parser("show", help="a checkpoint's description, as JSON")
    show.add_argument("file", metavar="FILE", help="a checkpoint file")


def run(args) -> int:
    try:
        if args.checkpoint == "show":
            print(json.dumps(read_checkpoint(args.file), indent=2))
            return 0
        new = Path(args.new)
        if new.suffix != SUFFIX:
            raise ValueError(f"{new}: NEW must be a {SUFFIX} file")
        if new.resolve() == Path(args.old).resolve():
            raise ValueError(f"{new}: NEW must not be OLD")
        if new.exists() and not args.force:
            raise ValueError(f"{new}: exists (--force replaces it)")
        print(f"wrote {convert(Path(args.old), new)}")
        return 0
    except ValueError as err:
        print(f"flatland-ma checkpoint {args.checkpoint}: {err}", file=sys.stderr)
        return 2


def convert(old: Path, new: Path) -> Path:
    """Write the data-only checkpoint ``new`` from the old-format checkpoint ``old``."""
    try:
        import torch
    except ImportError as err:
        raise ValueError(
            f"{old}: converting needs torch (pip install torch safetensors; or, in a clone "
            "of flatland_ma, its train extra: pip install -e '.[train]')"
        ) from err
    from flatland_ma.policies.networks import build_network

    blob, _ = read_regular_file(old)
    if not written_by_torch_save(blob):
        raise ValueError(f"{old}: not a checkpoint of the old torch format")
    try:
        data = torch.load(io.BytesIO(blob), map_location="cpu", weights_only=True)
    except Exception as err:  # anything torch refuses: say which file and why
        raise ValueError(f"{old}: torch cannot read it with weights_only=True ({err})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT or data.get("version") != 1:
        raise ValueError(f"{old}: not a flatland_ma policy checkpoint of version 1")
    model = data.get("model")
    if not isinstance(model, dict) or not all(isinstance(t, torch.Tensor) for t in model.values()):
        raise ValueError(
            f"{old}: no 'model' weights: only checkpoints written by the baselines' PPO, A2C "
            "and A3C convert"
        )
    algorithm, args = data.get("algorithm"), data.get("args") or {}
    observation_space, action_space = _spaces(old, data)
    spaces = {
        "observation": space_description(observation_space),
        "action": space_description(action_space),
    }
    kind, arguments = _network(old, algorithm, args, model)
    try:
        network = build_network(kind, spaces, arguments)
        network.load_state_dict(model, strict=True, assign=True)
    except (ValueError, RuntimeError) as err:
        raise ValueError(
            f"{old}: model: its weights do not fit the {kind} network ({err})"
        ) from None
    return write_checkpoint(
        new,
        network,
        scenario=data["scenario"],
        observation_space=observation_space,
        action_space=action_space,
        optimizer=data.get("optimizer"),
        extra={key: data[key] for key in KEPT if key in data},
    )


def _network(old: Path, algorithm: Any, args: dict, model: dict) -> tuple[str, dict]:
    """The network's kind and arguments, from the training arguments the old file kept."""
    channels = 4 if args.get("use_depth") else 3
    hidden = int(args.get("hidden", 128))
    if algorithm == "ppo":
        critic = model.get("critic.0.weight")
        return "ppo", {
            "hidden": hidden,
            "channels": channels,
            "network": args.get("network", "strided"),
            "state_size": 0 if critic is None else int(critic.shape[1]),
        }
    if algorithm in ("a2c", "a3c"):
        return "a3c", {"channels": channels, "hidden": hidden}
    raise ValueError(f"{old}: algorithm {algorithm!r}: only ppo, a2c and a3c checkpoints convert")


def _spaces(old: Path, data: dict) -> tuple[Any, Any]:
    """The spaces of an agent of the checkpoint's scenario whose spaces read as the
    checkpoint's (padded as in training if it was)."""
    from flatland_ma.envs.padding import Padding
    from flatland_ma.envs.parallel import FlatlandParallelEnv

    scenario, overrides = data.get("scenario"), data.get("overrides") or {}
    if not isinstance(scenario, str) or not isinstance(overrides, dict):
        raise ValueError(f"{old}: scenario and overrides must be a name and a mapping")
    try:
        env = FlatlandParallelEnv(scenario, **overrides)
    except Exception as err:  # the scenario is gone or changed: say so
        raise ValueError(f"{old}: its scenario {scenario!r} cannot be made ({err})") from None
    padding = Padding.of(env) if data.get("padded") else None
    for agent in env.possible_agents:
        observation = env.observation_space(agent) if padding is None else padding.space
        action = env.action_space(agent)
        if (str(observation), str(action)) == (
            data.get("observation_space"),
            data.get("action_space"),
        ):
            return observation, action
    raise ValueError(
        f"{old}: no agent of {scenario} has the spaces it was trained for "
        f"({data.get('observation_space')}, {data.get('action_space')})"
    )
