"""The RLlib script end to end in its own environment (``make test-rllib``): one iteration
on a local Ray instance with a remote env runner, which must import flatland_ma itself."""

import subprocess
import sys

from baselines import rllib_ppo


def test_one_iteration_of_shared_ppo_on_four_agents(tmp_path):
    checkpoint = tmp_path / "algo"
    args = ["--iterations", "1", "--batch", "1200", "--fragment", "100"]
    results = rllib_ppo.main([*args, "--num-env-runners", "1", "--checkpoint", str(checkpoint)])
    assert len(results) == 1
    runners = results[0]["env_runners"]
    assert runners["num_env_steps_sampled"] >= 1200
    # Every agent's steps went to the one shared policy.
    per_agent = runners["num_agent_steps_sampled"]
    assert set(per_agent) == {f"agent_{k}" for k in range(4)}
    assert len(set(per_agent.values())) == 1 and min(per_agent.values()) >= 1200
    per_module = runners["num_module_steps_sampled"]
    assert set(per_module) == {"shared"} and per_module["shared"] == sum(per_agent.values())
    assert runners["num_episodes"] >= 1  # 500-step episodes: at least two ended
    assert checkpoint.is_dir() and any(checkpoint.iterdir())


def test_gymnasium_ids_that_name_the_module_work_in_a_fresh_process():
    code = (
        "import gymnasium; "
        "env = gymnasium.make('flatland_ma:flatland_ma/FruitsPoisons-v0'); "
        "print(env.reset(seed=0)[0].shape)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "(64, 4)"
