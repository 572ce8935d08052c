"""Hostile use of the Python API: actions of the wrong shape or kind, sizes beyond the work
budget, two threads on one env, calls out of order, and bodies and sensors at the edge.

Each snippet must raise the documented error with words that say what is wrong (never an
"internal error", a hang or a MemoryError), or work.
"""

from __future__ import annotations

from tests.hostile.inputs import Input, bounded, located, raises, returns, snippet

P = "issue 26: API"
BATCH = (
    "import flatland_ma\n"
    "env = flatland_ma.BatchedParallelEnv('fruits_poisons', num_worlds={worlds})\n"
    "env.reset(seed=0)\n"
)
SINGLE = "import flatland_ma\nenv = flatland_ma.parallel_env('fruits_poisons')\n"
RESET = SINGLE + "env.reset(seed=0)\n"
TWO_THREADS = """import threading
{make}
env.reset(seed=0)
errors = []
both = threading.Barrier(2)

def steps():
    both.wait()  # start together, so that the steps overlap however busy the machine is
    try:
        for _ in range({steps}):
            if errors:
                return
            env.step({actions})
    except RuntimeError as err:
        errors.append(err)

threads = [threading.Thread(target=steps, daemon=True) for _ in range(2)]
for thread in threads:
    thread.start()
for thread in threads:
    thread.join()
env.close()
if errors:
    raise errors[0]
"""
SHARDED = "import flatland_ma\nenv = flatland_ma.ShardedParallelEnv('fruits_poisons', 4, shards=2)"
BATCHED = "import flatland_ma\nenv = flatland_ma.BatchedParallelEnv('fruits_poisons', 4)"
ACTION = "ValueError", "TypeError"
SEED = "ValueError", "TypeError", "Error"
"""A bad seed: gymnasium's own ``Error`` (from ``seeding.np_random``) is the convention."""
MAPS = "[rgb, semantic, visibility]"


def batch(name: str, code: str, expect, worlds: int = 2, **options) -> Input:
    return Input(name, snippet(BATCH.format(worlds=worlds) + code), expect, **options)


def threads(name: str, make: str, actions: str, steps: int = 300, **options) -> Input:
    code = TWO_THREADS.format(make=make, actions=actions, steps=steps)
    return Input(name, snippet(code), raises("RuntimeError", "thread"), **options)


def sensors(sensor: str, agents: int = 1) -> str:
    """Build, reset and step ``fruits_poisons`` with ``agents`` agents each carrying the
    sensors of the YAML flow list ``sensor``."""
    return (
        "import yaml, flatland_ma\n"
        f"sensors = yaml.safe_load({sensor!r})\n"
        f"env = flatland_ma.parallel_env('fruits_poisons', n_agents={agents}, "
        "arena={'size': [3000, 3000]}, agent={'sensors': sensors})\n"
        "env.reset(seed=0)\n"
        "for _ in range(5):\n"
        "    env.step({a: env.action_space(a).sample() for a in env.agents})\n"
    )


BATCHED_CASES = [
    batch("batch_step_none", "env.step(None)", raises(ACTION, "action")),
    batch("batch_step_dict_one_world", "env.step({'agent_0': 0})", raises(ACTION, "action"), 1),
    batch(
        "batch_step_dict_two_worlds", "env.step({'agent_0': 0, 'x': 1})", raises(ACTION, "action")
    ),
    batch("batch_step_strings", "env.step(['left', 'right'])", raises(ACTION, "left")),
    batch("batch_step_nan", "env.step([float('nan'), 0])", raises(ACTION, "nan")),
    batch("batch_step_out_of_range", "env.step([7, 0])", raises(ACTION, "7")),
    batch("batch_step_one_too_few", "env.step([0])", raises(ACTION, "action")),
    batch(
        "batch_step_2d",
        "import numpy as np\nenv.step(np.zeros((2, 2), int))",
        raises(ACTION, "action"),
    ),
    batch("batch_reset_seed_negative", "env.reset(seed=-1)", raises(SEED, "seed")),
    Input(
        "batch_step_before_reset",
        snippet("import flatland_ma\nflatland_ma.BatchedParallelEnv('fruits_poisons').step([0])"),
        raises("RuntimeError", "reset"),
    ),
    Input(
        "batch_num_worlds_zero",
        snippet("import flatland_ma\nflatland_ma.BatchedParallelEnv('fruits_poisons', 0)"),
        raises("ValueError", "num_worlds"),
    ),
    Input(
        "batch_num_worlds_float",
        snippet("import flatland_ma\nflatland_ma.BatchedParallelEnv('fruits_poisons', 2.5)"),
        raises("ValueError", "num_worlds"),
    ),
    Input(
        # builds worlds until the memory runs out while the budget does not count them
        "batch_num_worlds_10_to_9",
        snippet("import flatland_ma\nflatland_ma.BatchedParallelEnv('fruits_poisons', 10**9)"),
        raises("ValueError", "work budget"),
        slow=True,
    ),
    Input(
        "make_vec_100000",
        snippet(
            "import gymnasium, flatland_ma\n"
            "gymnasium.make_vec('flatland_ma/FruitsPoisons-v0', num_envs=100000)"
        ),
        raises("ValueError", "work budget"),
        slow=True,
    ),
    Input(
        "make_vec_zero",
        snippet(
            "import gymnasium, flatland_ma\n"
            "gymnasium.make_vec('flatland_ma/FruitsPoisons-v0', num_envs=0)"
        ),
        raises("ValueError", "num"),
    ),
    Input(
        "sharded_shards_zero",
        snippet(
            "import flatland_ma\nflatland_ma.ShardedParallelEnv('fruits_poisons', 2, shards=0)"
        ),
        raises("ValueError", "shards"),
    ),
    threads("two_threads_on_a_batched_env", BATCHED, "[0, 1, 2, 0]"),
    # deadlocked until the time limit before the sharded env had a guard; its shards start
    # fresh interpreters (tens of seconds on a busy machine)
    threads(
        "two_threads_on_a_sharded_env",
        SHARDED,
        "[0, 1, 2, 0]",
        steps=100,
        slow=True,
        time_limit=120.0,
    ),
    # an episode long enough for both threads' steps: the only error left is the guard's
    threads(
        "two_threads_on_a_single_env",
        "import flatland_ma\nenv = flatland_ma.parallel_env('fruits_poisons', max_cycles=10**6)\n",
        "{'agent_0': 1}",
        steps=3000,
    ),
]

SINGLE_CASES = [
    Input(
        "unknown_keyword",
        snippet(SINGLE.replace("')", "', colour=3)")),
        raises("TypeError", "colour"),
    ),
    Input(
        "step_before_reset",
        snippet(SINGLE + "env.step({'agent_0': 0})"),
        raises("RuntimeError", "reset"),
    ),
    Input("state_before_reset", snippet(SINGLE + "env.state()"), raises("RuntimeError", "reset")),
    Input("reset_seed_negative", snippet(SINGLE + "env.reset(seed=-1)"), raises(SEED, "seed")),
    Input("reset_seed_a_string", snippet(SINGLE + "env.reset(seed='x')"), raises(SEED, "seed")),
    Input("reset_seed_a_float", snippet(SINGLE + "env.reset(seed=1.5)"), raises(SEED, "seed")),
    Input("step_none", snippet(RESET + "env.step(None)"), raises(ACTION, "action")),
    Input("step_a_list", snippet(RESET + "env.step([0])"), raises(ACTION, "action")),
    Input(
        "step_out_of_range",
        snippet(RESET + "env.step({'agent_0': 7})"),
        raises("ValueError", "agent_0"),
    ),
    Input(
        "step_unknown_agent",
        snippet(RESET + "env.step({'nobody': 0})"),
        raises(("ValueError", "KeyError"), "nobody"),
    ),
    Input(
        "space_of_unknown_agent",
        snippet(SINGLE + "env.observation_space('nobody')"),
        raises(("ValueError", "KeyError"), "nobody"),
    ),
    Input("close_twice", snippet(RESET + "env.close()\nenv.close()"), returns()),
    Input(
        "aec_step_before_reset",
        snippet("import flatland_ma\nenv = flatland_ma.env('fruits_poisons')\nenv.step(0)"),
        raises(("RuntimeError", "AssertionError"), "reset"),
    ),
    Input(
        "gym_step_before_reset",
        snippet(
            "import gymnasium, flatland_ma\ngymnasium.make('flatland_ma/FruitsPoisons-v0').step(0)"
        ),
        raises(("RuntimeError", "ResetNeeded"), "reset"),
    ),
]

BODY_CASES = [
    Input(
        "touch_max_force_subnormal",
        snippet(sensors("[{type: touch, max_force: 5.0e-324}]")),
        bounded(),
    ),
    Input(
        "touch_max_force_tiny",
        snippet(sensors("[{type: touch, max_force: 1.0e-300}]")),
        bounded(),
    ),
    Input(
        "topdown_64_agents_16_maps_256",
        snippet(
            sensors(
                "["
                + ", ".join(
                    f"{{type: topdown, name: m{k}, size: 256, channels: {MAPS}}}" for k in range(16)
                )
                + "]",
                agents=64,
            )
        ),
        located(None, "work budget"),
    ),
]

CASES = [*BATCHED_CASES, *SINGLE_CASES, *BODY_CASES]
