"""Many worlds at once: the batched env (``BatchedParallelEnv``), the same worlds over
processes (``ShardedParallelEnv``), and the Gymnasium vector env of a single-agent
scenario (``FlatlandVectorEnv``, what ``gymnasium.make_vec`` builds)::

    from flatland_ma.vector import BatchedParallelEnv
    batch = BatchedParallelEnv("fruits_poisons_multi", num_worlds=256)

They live in ``flatland_ma.envs.vector``, ``flatland_ma.envs.shards`` and
``flatland_ma.envs.gym_vector``.
"""

from flatland_ma.envs.gym_vector import FlatlandVectorEnv
from flatland_ma.envs.shards import ShardedParallelEnv
from flatland_ma.envs.vector import AUTORESET_MODE, BatchedParallelEnv

__all__ = ["AUTORESET_MODE", "BatchedParallelEnv", "FlatlandVectorEnv", "ShardedParallelEnv"]
