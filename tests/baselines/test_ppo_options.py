"""The learning options of ``baselines.ppo``: presets, the team's reward, potential-based
shaping, and the CPU time a run's summary records."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import flatland_ma
from baselines.ppo import Args
from baselines.ppo_presets import PRESETS, with_preset
from baselines.shaping import DeliveryPotential, Shaping, learning_reward, team_rewards
from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.scenario.schema import ScenarioSpec
from tests.module_runner import run_module


def test_a_preset_fills_only_the_options_left_at_their_defaults():
    chosen = with_preset(Args(preset="fruits_poisons", seed=3, ent_coef=0.05))
    assert chosen.scenario == "fruits_poisons" and chosen.seed == 3
    assert chosen.ent_coef == 0.05  # set by hand: kept
    assert chosen.num_envs == PRESETS["fruits_poisons"]["num_envs"] != Args().num_envs
    assert with_preset(Args()) == Args()
    with pytest.raises(ValueError, match="no preset 'nope'"):
        with_preset(Args(preset="nope"))


def test_the_team_reward_gives_every_agent_its_worlds_sum():
    reward = np.array([1.0, 0.0, -2.0, 5.0, 0.5, 0.5])
    assert team_rewards(reward, 2).tolist() == [1.0, 1.0, 3.0, 3.0, 1.0, 1.0]
    assert team_rewards(reward, 1).tolist() == reward.tolist()


def _play(env, steps, seed):
    """``steps`` steps of uniformly random actions, drawn from ``seed``."""
    env.single_action_space.seed(seed)
    for _ in range(steps):
        actions = np.stack([env.single_action_space.sample() for _ in range(env.num_slots)])
        yield env.step(actions)


def test_delivery_shaping_is_a_difference_of_potentials_that_is_not_in_the_reward():
    env = BatchedParallelEnv("coop_carry", num_worlds=2, pad=True, copy=True)
    env.reset(seed=0)
    potential = DeliveryPotential(env)
    phi = [potential(env.state())]
    shaping = Shaping(potential, coef=2.0, gamma=1.0)
    shaping.start(env)
    terms, rewards = [], []
    for _, reward, terminated, _, _ in _play(env, 40, 0):
        terms.append(shaping(env, terminated))
        phi.append(potential(env.state()))
        rewards.append(reward)
    assert not np.any(np.concatenate(rewards))  # random play delivers nothing
    # With gamma 1 the terms telescope: their sum is the change of the potential.
    assert np.allclose(np.sum(terms, axis=0), 2.0 * (phi[-1] - phi[0]))
    assert np.any(np.sum(terms, axis=0) != 0.0)  # the agents moved: shaping paid something
    env.close()


def test_the_potential_is_highest_with_the_crate_in_the_zone_and_the_agent_beside_it():
    env = BatchedParallelEnv("coop_carry", num_worlds=1, pad=True)
    env.reset(seed=0)
    potential = DeliveryPotential(env)
    state = env.state().copy()
    start = potential(state)
    for ix, iy, ox, oy, (x0, y0, x1, y1) in potential.agents:
        state[0, ox], state[0, oy] = (x0 + x1) / 2 / 400, (y0 + y1) / 2 / 300
        state[0, ix], state[0, iy] = state[0, ox], state[0, oy]
    assert np.allclose(potential(state), 0.0)
    assert np.all(start < 0.0)
    env.close()
    with pytest.raises(ValueError, match="delivers nothing"):
        DeliveryPotential(BatchedParallelEnv("fruits_poisons", num_worlds=1))


def test_the_learning_reward_adds_team_and_shaping_terms_and_is_none_without_them():
    env = BatchedParallelEnv("coop_carry", num_worlds=2, pad=True, copy=True)
    env.reset(seed=1)
    assert learning_reward(Args(), env) is None
    learn_from = learning_reward(Args(team_reward=True, shaping=1.0, gamma=0.9), env)
    check = Shaping(DeliveryPotential(env), 1.0, 0.9)
    check.start(env)
    assert learn_from is not None
    for _, reward, terminated, _, _ in _play(env, 10, 1):
        reward = reward + np.array([1.0, 0.0, 0.0, 3.0])  # as if agents had scored
        expected = team_rewards(reward, 2) + check(env, terminated)
        assert np.allclose(learn_from(reward, terminated), expected)
    with pytest.raises(ValueError, match="shaping must be"):
        learning_reward(Args(shaping=-1.0), env)
    env.close()
    rivals = BatchedParallelEnv("tug_of_war", num_worlds=1, pad=True)
    rivals.reset(seed=0)
    with pytest.raises(ValueError, match="teams score against each other .*red_goal, blue_goal"):
        learning_reward(Args(team_reward=True), rivals)
    assert learning_reward(Args(shaping=1.0), rivals) is not None  # each agent's own reward
    rivals.close()


def test_a_run_records_its_cpu_time_and_the_load_and_logs_the_scenarios_return(tmp_path):
    csv = tmp_path / "seed_0.csv"
    result = run_module(
        *[
            "baselines.ppo",
            "--scenario",
            "fruits_poisons",
            "--num-envs",
            "1",
            "--num-steps",
            "125",
            "--total-timesteps",
            "500",
            "--checkpoint-every",
            "0",
            "--no-tensorboard",
            "--csv",
            str(csv),
        ]
    )
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(csv.with_suffix(".json").read_text())
    assert summary["cpu_seconds"] > 0
    assert len(summary["load_average_start"]) == len(summary["load_average_end"]) == 3
    rows = csv.read_text().splitlines()
    assert len(rows) == 2  # one episode of 500 steps


def test_a_curriculum_trains_on_each_stage_in_turn_for_its_steps(tmp_path):
    stream = tmp_path / "short_first.yaml"
    stream.write_text(
        "tasks:\n"
        "  - {name: short, scenario: fruits_poisons, overrides: {episode: {max_steps: 50}},"
        " steps: 200}\n"
        "  - {name: long, scenario: fruits_poisons, overrides: {episode: {max_steps: 100}},"
        " steps: 200}\n"
    )
    csv = tmp_path / "seed_0.csv"
    run = ["--scenario", "fruits_poisons"]
    run += ["--curriculum", str(stream), "--num-envs", "1", "--num-steps", "50"]
    run += ["--checkpoint-every", "0", "--no-tensorboard", "--csv", str(csv)]
    result = run_module("baselines.ppo", *run)
    assert result.returncode == 0, result.stderr[-3000:]
    steps = [int(row.split(",")[2]) for row in csv.read_text().splitlines()[1:]]
    summary = json.loads(csv.with_suffix(".json").read_text())
    short, long = summary["curriculum"]
    assert (short["name"], short["began"], long["name"]) == ("short", 0, "long")
    # The stage changes at the end of the first rollout (50 steps) after its 200 steps.
    assert 200 <= long["began"] < 250
    # Four episodes of 50 steps, then one of 100: the second stage's worlds.
    assert steps == [50, 100, 150, 200, long["began"] + 100]


@pytest.mark.parametrize(
    "path", sorted((Path(__file__).parents[2] / "baselines" / "curricula").glob("*.yaml"))
)
def test_the_shipped_curricula_load_and_end_on_their_task(path):
    from baselines.curriculum import curriculum_stages

    stages = curriculum_stages(path)
    assert len(stages) >= 2 and all(stage.steps > 0 for stage in stages)
    assert stages[-1].spec == flatland_ma.load_scenario(stages[-1].name)  # the task itself
    # easier first: an easier scenario, or a scripted partner beside the learners
    assert all(
        stage.spec != stages[-1].spec or stage.background is not None for stage in stages[:-1]
    )
    assert stages[-1].focal is None  # in the task itself every agent learns


def _told_first(tmp_path, steps: int = 64) -> Path:
    """signal_rooms: the seeker alone learning beside the scripted Signaller, then both."""
    stream = tmp_path / "told_first.yaml"
    stream.write_text(
        "tasks:\n"
        f"  - {{name: told, scenario: signal_rooms, focal: [seeker], background: signaller,"
        f" steps: {steps}}}\n"
        f"  - {{name: both, scenario: signal_rooms, steps: {steps}}}\n"
    )
    return stream


def _told_first_args(tmp_path, **options) -> Args:
    """A short run of ``_told_first``, without checkpoints or scalars."""
    return Args(
        scenario="signal_rooms",
        curriculum=str(_told_first(tmp_path)),
        checkpoint_every=0,
        tensorboard=False,
        csv=str(tmp_path / "seed_0.csv"),
        **options,
    )


def test_a_curriculum_stage_with_a_background_trains_its_focal_agents_beside_it(tmp_path):
    """In the first stage the guides' slots play the Signaller: every step they act, they
    name the room that holds their world's goal, and only the seekers learn (their steps
    alone count); in the second every agent learns, and the checkpoint says whom it met."""
    import time

    from baselines.ppo import Training
    from flatland_ma.policies.signals import rooms_of
    from flatland_ma.world.entities import Item

    args = _told_first_args(tmp_path, num_envs=2, num_steps=16)
    run = Training(args)
    assert run.learns.tolist() == [False, True, False, True]  # guide_0, seeker_0 per world
    run.iterate(1, time.perf_counter())
    words = np.asarray(run.rollout._actions)[:, [0, 2], -1]  # the guides' words
    for w, world in enumerate(run.env.worlds):
        goal = next(i for i in world.episode.world.of_type(Item) if i.visible and i.reward > 0)
        x, y = goal.body.position
        room = [r[0] <= x <= r[2] and r[1] <= y <= r[3] for r in rooms_of(world.spec)].index(True)
        assert set(words[:, w].tolist()) == {room}  # 16 steps: no goal reached yet
    assert not np.asarray(run.rollout._acting)[:, [0, 2]].any()  # the guides' are not learnt
    assert run.episodes.global_step == 2 * 16  # the seekers' steps alone
    while run.stage == 0:
        run.iterate(2, time.perf_counter())
    assert run.learns.all() and not run.rollout.partners
    from baselines.ppo import trained_with

    assert trained_with(args, run.stages) == ["self", "signaller"]


def _open_room(goal_at: float, wall: bool, reward: float = 10.0):
    """A 300 x 200 room, the agent near (50, 50) facing +x, a 20 x 20 goal zone centred at
    (``goal_at``, 50); with ``wall``, a wall across x = 150 but for a gap at the top."""
    spec = {
        "arena": {"size": [300, 200]},
        "zones": [{"name": "goal", "rect": [goal_at - 10, 40, goal_at + 10, 60], "reward": reward}],
        "agent": {"spawn": {"area": [20, 20, 80, 80], "heading": 0}},
    }
    if wall:
        spec["walls"] = [{"start": [150, 0], "end": [150, 170]}]
    return ScenarioSpec.model_validate(spec)


def test_the_goal_potential_is_minus_the_walking_distance_to_the_zone():
    from baselines.shaping import GoalPotential, potential_of

    env = BatchedParallelEnv(_open_room(250, wall=False), num_worlds=1)
    env.reset(seed=0)
    potential = GoalPotential(env)
    assert isinstance(potential_of(env), GoalPotential)  # auto: no deliveries, a goal
    cell = env.worlds[0].running.grid.cell
    body = env.worlds[0].running.bodies[0].body
    body.position = (50, 50)
    # In the open the way is straight: from x = 50 to the zone's near edge at x = 240.
    assert potential()[0] == pytest.approx(-190 / 100, abs=1.5 * cell / 100)
    walled = BatchedParallelEnv(_open_room(250, wall=True), num_worlds=1)
    walled.reset(seed=0)
    walled.worlds[0].running.bodies[0].body.position = (50, 50)
    # Round the wall through the gap above it, where centres pass at y 180-190 and must keep
    # 10 + 5 from the wall's middle. A diagonal grid step counts as one: 130 up to the gap
    # (to x = 135, y = 180), 30 along it, 130 down to the zone's edge; 190 straight.
    assert GoalPotential(walled)()[0] == pytest.approx(-290 / 100, abs=2 * cell / 100)
    # Walking to the zone raises the potential, to 0 inside it.
    before = potential()[0]
    body.position = (150, 50)
    assert before < potential()[0] < 0
    body.position = (250, 50)
    assert potential()[0] == 0.0
    env.close()
    walled.close()


def test_goal_shaping_telescopes_and_refuses_scenarios_without_a_paying_zone():
    from baselines.shaping import GoalPotential, potential_of

    env = BatchedParallelEnv("explore_goal", num_worlds=2)
    env.reset(seed=0)
    potential = GoalPotential(env)
    phi = [potential()]
    shaping = Shaping(potential, coef=1.5, gamma=1.0)
    shaping.start(env)
    terms = []
    for _, _, terminated, _, _ in _play(env, 30, 0):
        terms.append(shaping(env, terminated))
        phi.append(potential())
    assert np.allclose(np.sum(terms, axis=0), 1.5 * (phi[-1] - phi[0]))
    assert np.all(phi[0] < 0) and np.any(np.sum(terms, axis=0) != 0.0)
    env.close()
    plain = BatchedParallelEnv(_open_room(250, wall=False, reward=0.0), num_worlds=1)
    plain.reset(seed=0)
    with pytest.raises(ValueError, match="no zone or item pays a reward"):
        GoalPotential(plain)
    with pytest.raises(ValueError, match="nothing to shape towards"):
        potential_of(plain)
    with pytest.raises(ValueError, match="shaping_potential must be one of"):
        potential_of(plain, "nearest")
    plain.close()


def _still(env):
    """Every slot turns on the spot (these scenarios' agents have no action to stand)."""
    turn = env.worlds[0].actuators[0].index("rotate_left")
    return np.full(env.num_slots, turn, env.single_action_space.dtype)


def test_the_goal_potential_goes_by_the_switch_and_does_not_jump_when_it_opens_the_door():
    from baselines.shaping import GoalPotential

    env = BatchedParallelEnv("switch_door", num_worlds=1)
    env.reset(seed=0)
    episode = env.worlds[0].running
    potential = GoalPotential(env)
    plate = next(z for z in episode.world.zones if z.name == "plate")
    body = episode.bodies[0].body
    cell = episode.grid.cell
    # Shut: the way goes to the 40 x 40 plate and from it through the doorway (x = 250) to
    # the goal at x = 340. A diagonal grid step counts one, so a way is at least the larger
    # of its x and y spans and at most its straight length (and a few cells).
    body.position = (30, 30)
    far = -potential()[0] * 100
    (px, py), goal_x = plate.centre, 340 - 6
    least = max(abs(px - 30), abs(py - 30)) - 20 + goal_x - (px + 20)
    most = math.dist((30, 30), (px, py)) + math.dist((px, py), (250, 125)) + goal_x - 250
    assert least - 2 * cell <= far <= most + 6 * cell
    body.position = plate.centre
    on_plate = potential()[0]
    assert -far / 100 < on_plate < 0.0
    env.step(_still(env))  # standing on the plate opens the door for good
    assert episode.doors[0].is_open
    # Open: the same way from here, so the potential does not jump.
    assert potential()[0] == pytest.approx(on_plate, abs=2 * cell / 100)
    env.close()


def test_the_goal_potential_goes_by_the_key_and_does_not_jump_when_it_is_taken():
    from baselines.shaping import GoalPotential
    from flatland_ma.world.entities import Item

    for seed in range(3):
        env = BatchedParallelEnv("key_door", num_worlds=1)
        env.reset(seed=seed)
        episode = env.worlds[0].running
        potential = GoalPotential(env)
        key = next(item for item in episode.world.of_type(Item) if item.group.key)
        cell = episode.grid.cell
        body = episode.bodies[0].body
        body.position = key.body.position
        at_key = potential()[0]
        # The key pays 1 but is on the way, not its end: the goal is still to walk to.
        assert at_key < -(340 - 250) / 100
        _, reward, *_ = env.step(_still(env))
        assert reward[0] == 1.0 and episode.task.records[0].keys == {"key"}
        assert potential()[0] == pytest.approx(at_key, abs=2 * cell / 100)
        env.close()


@pytest.mark.parametrize("scenario", ["key_door", "switch_door", "key_carry"])
def test_the_goal_potential_rises_along_the_scripted_solvers_way_without_a_fall(scenario):
    """The solver walks to the key (or the plate, or the key object, then carries it to the
    door) and on to the goal: the whole way shrinks at every step, so Phi never falls by
    more than a cell's rounding, not at the key, the plate or the door."""
    from types import SimpleNamespace

    from baselines.shaping import GoalPotential
    from flatland_ma.envs.parallel import FlatlandParallelEnv
    from flatland_ma.policies.named import make_policy

    env = FlatlandParallelEnv(scenario)
    observations, _ = env.reset(seed=0)
    agent = env.possible_agents[0]
    solver = make_policy(env.spec.reference.solver, env, agent)
    worlds = [SimpleNamespace(running=env.episode, spec=env.spec)]
    potential = GoalPotential(SimpleNamespace(worlds=worlds, agents_per_world=1))
    cell = env.episode.grid.cell
    phi, total = [potential()[0]], 0.0
    while env.agents:
        observations, rewards, *_ = env.step({agent: solver.act(observations[agent])})
        total += rewards[agent]
        if env.agents:
            phi.append(potential()[0])
    assert total >= 10.0  # the solver reached the goal
    assert phi[0] < -1.0 and np.diff(phi).min() >= -cell / 100 - 1e-9
    env.close()


def test_the_shaping_discount_is_the_learners_unless_set_and_refused_above_one():
    from baselines.shaping import shaping_gamma

    assert shaping_gamma(Args(gamma=0.9)) == 0.9
    assert shaping_gamma(Args(gamma=0.9, shaping_gamma=1.0)) == 1.0
    for bad in (1.5, math.nan, math.inf):
        with pytest.raises(ValueError, match="shaping_gamma must be at most 1"):
            shaping_gamma(Args(shaping_gamma=bad))
    # At a discount of 1 the term is the plain progress: standing still earns nothing.
    env = BatchedParallelEnv("key_door", num_worlds=2)
    env.reset(seed=0)
    shaping = Shaping(potential_of_goal(env), coef=1.0, gamma=1.0)
    shaping.start(env)
    env.step(_still(env))
    assert np.all(shaping(env, np.zeros(env.num_slots, bool)) == 0.0)
    env.close()


def potential_of_goal(env):
    from baselines.shaping import potential_of

    return potential_of(env, "goal")


def test_delivery_shaping_leads_each_team_to_its_own_area():
    from flatland_ma.world.entities import Obstacle

    env = BatchedParallelEnv("tug_of_war", num_worlds=1, pad=True)
    env.reset(seed=0)
    episode = env.worlds[0].running
    potential = DeliveryPotential(env)
    [ball] = [o for o in episode.world.of_type(Obstacle) if o.tag == "ball"]
    ball.body.position = (100, 150)  # 60 from red's area (x < 40), 360 from blue's (x > 460)
    for body in episode.bodies:
        body.body.position = (100, 100)  # every agent 50 from the ball
    phi = potential(env.state())
    assert phi[:2] == pytest.approx(-(60 + 25) / 100, abs=0.01)  # red_0, red_1
    assert phi[2:] == pytest.approx(-(360 + 25) / 100, abs=0.01)  # blue_0, blue_1
    env.close()


def test_the_runner_is_led_to_the_door_the_scout_opens_and_the_scout_to_the_plate():
    from baselines.shaping import GoalPotential

    env = BatchedParallelEnv("plate_relay", num_worlds=1, pad=True)
    env.reset(seed=0)
    episode = env.worlds[0].running
    potential = GoalPotential(env)
    scout, runner = potential()
    # The runner (radius 12) cannot go down the scout's passage to the plate: its way is
    # the walk to the goal as though the door were open, so the door's opening changes
    # nothing for it; the scout's way goes by the plate.
    episode.bodies[0].body.position = (100, 212)  # the scout on the plate
    on_plate, _ = potential()
    assert scout < on_plate < 0.0
    env.step(np.full(env.num_slots, 1, env.single_action_space.dtype))  # both turn
    assert episode.doors[0].is_open
    assert potential()[1] == pytest.approx(runner, abs=2 * episode.grid.cell / 100)
    assert runner < -(350 - 250) / 100  # the runner starts west of the door
    env.close()


def test_with_learners_only_that_team_learns_and_the_others_act_at_random(tmp_path):
    from baselines import ppo
    from baselines.networks import Agent
    from baselines.ppo_learner import Rollout

    env = BatchedParallelEnv("tug_of_war", num_worlds=2, pad=True, copy=False)
    observation, _ = env.reset(seed=0)
    args = Args(scenario="tug_of_war", learners="red")
    learns = ppo.learner_slots(args, env)
    assert learns.tolist() == [True, True, False, False] * 2  # red_0, red_1, blue_0, blue_1
    agent = Agent(env.single_observation_space, env.single_action_space, hidden=8)
    rollout = Rollout(agent, env, observation, 8)
    rollout.learns = learns
    acted = []
    rollout.collect(agent, env, observation, 0.1, lambda *a: acted.append(a[-1]))
    assert not rollout.acting[:, ~learns].any() and rollout.acting[:, learns].all()
    assert acted == [4] * 8  # the red agents' steps alone
    sizes = np.array(agent.sizes)
    others = rollout.actions[:, ~learns].numpy()
    assert ((others >= 0) & (others < sizes)).all() and len(np.unique(others)) > 1
    with pytest.raises(ValueError, match="no such team \\(its teams: red, blue\\)"):
        ppo.learner_slots(replace(args, learners="green"), env)
    env.close()
    csv = tmp_path / "seed_0.csv"
    options = dict(num_envs=1, num_steps=64, total_timesteps=128, tensorboard=False)
    summary = ppo.main(replace(args, csv=str(csv), checkpoint_every=0, **options))
    assert summary["steps"] == 128  # two rollouts of the two red agents
    from flatland_ma.policies.checkpoint import read_checkpoint

    assert read_checkpoint(csv.with_suffix(".safetensors"))["trained_with"] == ["self", "random"]


def test_a_curriculum_without_the_channel_plays_every_stage_without_it(tmp_path):
    from baselines.ppo import Training

    args = _told_first_args(tmp_path, no_channel=True, num_envs=1, num_steps=8)
    run = Training(args)
    assert run.env.spec.channel is None and "messages" not in run.env.single_observation_space
    while run.stage == 0:
        run.iterate(1, 0.0)
    assert run.env.spec.channel is None
