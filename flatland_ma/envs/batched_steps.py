"""The array work of the batched env's step (``vector.BatchedParallelEnv``): a batch of
actions checked at once, every world's bodies driven at once, and whether a world's
observations can be copied from its kernel output in one go.

Each gives what the agent-by-agent path gives, number for number (tests/
test_batched_scenarios.py holds them to separate envs on every scenario).
"""

from __future__ import annotations

import numpy as np

from flatland_ma.agents.actuators import Actuator
from flatland_ma.agents.motors import Motors
from flatland_ma.envs.world_loop import WorldLoop
from flatland_ma.sensors.camera import Camera
from flatland_ma.sensors.sensor_suite import Sensors


def checked_at_once(
    actions, actuator: Actuator, worlds: list[WorldLoop], ended: list[bool], m: int
) -> list | None:
    """Each live agent's action, world by world (none for worlds ``ended``), as
    ``Actuator.check`` gives it, when ``actions`` is one array that lies in the space
    everywhere (integers of ``Discrete(n)``, or numbers in [-1, 1] of the continuous
    ``Box``); None otherwise, and the caller checks slot by slot (for the error that
    names the bad one, or for other kinds of action)."""
    if not isinstance(actions, np.ndarray) or actions.size == 0 or actuator.words:
        return None
    if actuator.mode == "discrete":
        if actions.ndim != 1 or actions.dtype.kind not in "iu":
            return None
        if actions.min() < 0 or actions.max() >= len(actuator.macros):
            return None
        values: list = actions.tolist()
    else:
        if actions.shape[1:] != actuator.space.shape or actions.dtype.kind not in "fiu":
            return None
        numbers = actions.astype(np.float64)
        if not np.isfinite(numbers).all() or np.abs(numbers).max() > 1.0:
            return None
        values = list(numbers)
    # Tuples: each env keeps its actions for pickling, and tuples of numbers are left out
    # of the garbage collector's scans (lists would make every step's add to them).
    return [
        ()
        if ended[w]
        else tuple(values[w * m : (w + 1) * m])
        if len(env.live) == m
        else tuple([values[w * m + i] for i in env.live])
        for w, env in enumerate(worlds)
    ]


def checked_by_slot(actions, worlds: list[WorldLoop], ended: list[bool], m: int) -> list[list]:
    """What ``checked_at_once`` gives, slot by slot through each world's
    ``check_action``; a bad action raises ``ValueError`` naming its world and slot."""
    checked: list[list] = []
    for w, env in enumerate(worlds):
        own = []
        if not ended[w]:
            for i in env.live:
                agent = env.possible_agents[i]
                try:
                    own.append(env.check_action(agent, actions[w * m + i]))
                except ValueError as err:
                    raise ValueError(f"world {w}, slot {w * m + i}: {err}") from None
        checked.append(own)
    return checked


def drive(
    motors: Motors, actuator: Actuator, stepped: list, checked: list[list], whole=None
) -> None:
    """Command the body of every live agent of the worlds ``stepped`` ((world, loop)
    pairs) in one call (``motors.Motors``: the numbers ``Actuator.apply`` would give).
    ``whole``: the batch's array of actions, checked at once, when every slot acts (every
    world stepped, every agent live): then the commands come from it in one go, else slot
    by slot from ``checked``."""
    if whole is not None:
        motors.drive_all(actuator.base_commands_of(whole))
        return
    m = len(stepped[0][1].possible_agents) if stepped else 0
    slots, bodies, actions = [], [], []
    for w, env in stepped:
        own = env.running.bodies
        for i, action in zip(env.live, checked[w]):
            slots.append(w * m + i)
            bodies.append(own[i])
            actions.append(action)
    if slots:
        motors.drive(
            np.array(slots, np.intp),
            actuator.base_commands(actions),
            np.array([body.touching for body in bodies], bool),
        )


def whole_image(sensors: Sensors) -> bool:
    """Whether every agent's observation is its one camera's rays as the kernel wrote
    them (RGB and depth, linear falloff, no noise), the cameras' rays in agent order and
    as many for each: then a world's observations are its ``image``, row for row."""
    cameras = sensors.cameras
    rays = len(sensors.image) // max(1, len(cameras))
    return sensors.per_agent == [[k] for k in range(len(cameras))] and all(
        isinstance(camera, Camera)
        and type(camera).read is Camera.read
        and camera.channels == ("rgb", "depth")
        and camera.decay is None
        and camera.noise is None
        and sensors.slices[k] == slice(k * rays, (k + 1) * rays)
        for k, camera in enumerate(cameras)
    )
