"""Going on with an interrupted ``baselines.ppo`` run (``--resume``).

A run writes a checkpoint every ``--checkpoint-every`` updates into its folder
(``update_NNNNN.safetensors``: the network, the optimiser's state and the run's
``progress``: ``policies.checkpoint_spec.Progress``). Run again with the same arguments
and ``--resume``, it goes on from the newest of them: the network and optimiser as they
were, the update, agent-step and episode counts, the curriculum's stage, and the log's
rows up to that agent-step (the rows of episodes that ended after it are dropped; they
will be played again). Nothing else of the interrupted process survives: the worlds
start new episodes, seeded from the run's seed and the update (``Resumed.seed``), and so
do the generators. A resumed run trains for the whole budget but is not the trajectory
of a run never interrupted; resumed at the same checkpoint twice, it is the same run
twice. Its JSON lists the agent-steps at which it resumed (``resumed_at``) and its CPU
and wall seconds include the earlier processes'.
"""

from __future__ import annotations

import re
from dataclasses import asdict, dataclass
from pathlib import Path

from flatland_ma.policies.checkpoint import SUFFIX, load_checkpoint

PERIODIC = re.compile(r"update_(\d+)" + re.escape(SUFFIX))
"""The name of a checkpoint written every ``checkpoint_every`` updates."""
SAME_RUN_EXCEPT = frozenset({"resume", "keep_checkpoints", "csv", "tensorboard"})
"""The arguments that may differ between a run and the run it goes on with: how it goes
on and what it keeps, where its folder is (it may have been moved), and its TensorBoard
events."""


def periodic_checkpoints(run_dir: Path) -> list[Path]:
    """The run's periodic checkpoints, oldest first."""
    if not run_dir.is_dir():
        return []
    found = [(int(m.group(1)), p) for p in run_dir.iterdir() if (m := PERIODIC.fullmatch(p.name))]
    return [p for _, p in sorted(found)]


def prune(run_dir: Path, keep: int) -> None:
    """Delete all but the newest ``keep`` periodic checkpoints (``keep`` 0: none; below
    0: every one)."""
    if keep != 0:
        found = periodic_checkpoints(run_dir)
        for path in found if keep < 0 else found[:-keep]:
            path.unlink()


@dataclass
class Resumed:
    """The newest checkpoint of an interrupted run, read and checked against the run's
    arguments (``find``); ``load`` puts its network and optimiser state in place."""

    path: Path
    update: int
    agent_steps: int
    episodes: int
    cpu_seconds: float
    wall_seconds: float
    resumed_at: list[int]
    began: list[int]
    state: dict

    @classmethod
    def find(cls, args, run_dir: Path) -> Resumed | None:
        """The newest periodic checkpoint in ``run_dir``, or None if there is none;
        ``ValueError`` naming the file if it is not one of this run (other arguments, no
        optimiser state or progress)."""
        found = periodic_checkpoints(run_dir)
        if not found:
            return None
        path = found[-1]
        info, _, state = load_checkpoint(path)
        progress, saved = info.get("progress"), info.get("args") or {}
        if progress is None or state["optimizer"] is None or info.get("update") is None:
            raise ValueError(f"{path}: no optimiser state or progress to go on from")
        ours, defaults = asdict(args), asdict(type(args)())
        # An option newer than the checkpoint counts as left at its default there.
        was = {**{k: v for k, v in defaults.items() if k not in saved}, **saved}
        keys = (set(ours) | set(was)) - SAME_RUN_EXCEPT
        differ = sorted(key for key in keys if was.get(key) != ours.get(key))
        if differ:
            shown = ", ".join(f"{k} {was.get(k)!r} (now {ours.get(k)!r})" for k in differ[:5])
            raise ValueError(f"{path}: written by a run of other arguments: {shown}")
        return cls(
            path,
            int(info["update"]),
            int(info["agent_steps"]),
            state=state,
            **{k: progress[k] for k in ("episodes", "cpu_seconds", "wall_seconds", "began")},
            resumed_at=[*progress["resumed_at"], int(info["agent_steps"])],
        )

    def seed(self, seed: int) -> int:
        """The seed of the worlds and generators from here on: one per run and update."""
        return seed * 1_000_003 + self.update

    def load(self, agent, optimizer) -> None:
        """The checkpoint's network and optimiser state into this run's; ``ValueError``
        naming the file if they do not fit (e.g. a scenario changed since: other spaces)."""
        adam = {k: v for k, v in self.state["optimizer"].items() if k != "novelty"}
        load_into(self.path, agent, self.state["model"], optimizer, adam)

    def novelty(self) -> dict:
        """The exploration bonus's state (``baselines.novelty``); ``ValueError`` naming
        the file if the checkpoint has none."""
        if "novelty" not in self.state["optimizer"]:
            raise ValueError(f"{self.path}: no exploration bonus's state to go on from")
        return self.state["optimizer"]["novelty"]


def start_from(agent, path: str) -> None:
    """``path``'s network weights into ``agent`` (``--init-from``); ``ValueError`` naming
    the file if it is no checkpoint or its network does not fit this run's."""
    from flatland_ma.policies.checkpoint import load_checkpoint

    _, _, state = load_checkpoint(path)
    load_into(path, agent, state["model"])


def load_into(path, agent, model: dict, optimizer=None, optimizer_state=None) -> None:
    """A checkpoint's weights (and optimiser state) into this run's network (and
    optimiser); ``ValueError`` naming ``path`` if they do not fit."""
    try:
        agent.load_state_dict(model)
        if optimizer is not None:
            optimizer.load_state_dict(optimizer_state)
    except (RuntimeError, ValueError, KeyError) as err:
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise ValueError(f"{path}: does not fit this run's network: {first}") from None


def progress(episodes: int, cpu: float, wall: float, resumed_at: list, began: list) -> dict:
    """A checkpoint's ``progress`` entry (``Resumed`` reads it back)."""
    return {
        "episodes": int(episodes),
        "cpu_seconds": round(float(cpu), 2),
        "wall_seconds": round(float(wall), 2),
        "resumed_at": [int(s) for s in resumed_at],
        "began": [int(s) for s in began],
    }
