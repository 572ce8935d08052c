"""A BenchMARL task for any scenario, so BenchMARL trains on flatland_ma with no glue::

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig
    from flatland_ma.integrations.benchmarl import flatland_task

    task = flatland_task("plate_relay")            # keyword overrides as parallel_env's
    Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(),
               model_config=MlpConfig.get_from_yaml(), seed=0,
               config=ExperimentConfig.get_from_yaml()).run()

BenchMARL builds its tasks as TorchRL ``PettingZooWrapper`` envs, which group agents by the
prefix of their names (``scout_0`` -> group ``scout``), take one flat vector per agent and
one ``Discrete`` (or ``Box``) action. So the task's env is ``flatland_ma.parallel_env(...,
flatten=True)`` (``flatland_ma.envs.flatten``), with channel actions numbered as one
``Discrete`` action (``flatland_ma.integrations.discrete.DiscreteActions``), the global
``state()`` for centralised critics, and a mask for agents that finish early (TorchRL's
``use_mask``: a finished agent's entries are zero until its world resets; BenchMARL 1.5
learns from them as from any step, as it does for its own tasks with varying agents).

BenchMARL is imported only with this module (install it in an environment of its own:
``tests/clients/requirements-benchmarl.txt`` and ``make test-clients``).
"""

from __future__ import annotations

from typing import Any

try:
    from benchmarl.environments.common import TaskClass  # pyright: ignore[reportMissingImports]
    from torchrl.data import Composite
    from torchrl.envs import EnvBase, PettingZooWrapper
except ImportError as err:  # the client is not a dependency: imported only with this module
    raise ImportError(
        "flatland_ma.integrations.benchmarl needs BenchMARL: pip install benchmarl"
    ) from err

from gymnasium import spaces

from flatland_ma.envs.parallel import FlatlandParallelEnv
from flatland_ma.integrations.discrete import DiscreteActions


def flatland_task(scenario: str = "fruits_poisons_multi", **overrides: Any) -> FlatlandTask:
    """The BenchMARL task of ``scenario`` (a name or a path), keyword ``overrides`` merged into
    the file as ``flatland_ma.parallel_env`` merges them."""
    return FlatlandTask(name=str(scenario), config={"scenario": scenario, **overrides})


class FlatlandTask(TaskClass):
    """A flatland_ma scenario as a BenchMARL task (the module's docstring); ``config`` holds
    ``scenario`` and the keyword overrides."""

    def _flatland_env(self) -> FlatlandParallelEnv:
        config = dict(self.config)
        scenario = config.pop("scenario")
        return FlatlandParallelEnv(scenario, flatten=True, **config)

    def _parallel_env(self) -> DiscreteActions:
        return DiscreteActions(self._flatland_env())

    def get_env_fun(self, num_envs: int, continuous_actions: bool, seed, device):
        def make() -> EnvBase:
            return PettingZooWrapper(
                self._parallel_env(),
                categorical_actions=True,
                use_mask=True,
                return_state=True,
                seed=seed,
                device=device,
            )

        return make

    def _action_spaces(self) -> list[spaces.Space]:
        env = self._parallel_env()
        return [env.action_space(agent) for agent in env.possible_agents]

    def supports_continuous_actions(self) -> bool:
        return all(isinstance(s, spaces.Box) for s in self._action_spaces())

    def supports_discrete_actions(self) -> bool:
        return all(isinstance(s, spaces.Discrete) for s in self._action_spaces())

    def max_steps(self, env: EnvBase) -> int:
        return int(self._flatland_env().step_limit or 0)

    def has_render(self, env: EnvBase) -> bool:
        return False

    def group_map(self, env: EnvBase) -> dict[str, list[str]]:
        return dict(env.group_map)  # type: ignore[attr-defined]

    def observation_spec(self, env: EnvBase) -> Composite:
        return _keep(env, "observation")

    def info_spec(self, env: EnvBase) -> Composite | None:
        return None

    def state_spec(self, env: EnvBase) -> Composite | None:
        return Composite({"state": env.observation_spec["state"].clone()})

    def action_spec(self, env: EnvBase) -> Composite:
        return env.full_action_spec

    def action_mask_spec(self, env: EnvBase) -> Composite | None:
        return None

    @staticmethod
    def env_name() -> str:
        return "flatland_ma"


def _keep(env: EnvBase, key: str) -> Composite:
    """Each group's ``key`` entry of the env's observation spec, nothing else."""
    spec = env.observation_spec.clone()
    for group in env.group_map:  # type: ignore[attr-defined]
        for name in list(spec[group].keys()):
            if name != key:
                del spec[group][name]
    del spec["state"]
    return spec
