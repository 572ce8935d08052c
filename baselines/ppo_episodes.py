"""The episodes of ``baselines.ppo``'s worlds as its rollouts step them: each slot's return
summed until its episode ends, and a world's agents logged together (the CSV and
TensorBoard) once every one of them has finished, since a world plays on while any of its
agents does."""

from __future__ import annotations

from collections import deque

import numpy as np

from baselines.common import RunLog
from baselines.writer import Scalars


class Episodes:
    """The run's agent-steps and episodes so far; ``after_step`` is the rollouts' callback."""

    def __init__(
        self,
        slots: int,
        agents_per_world: int,
        names: list[str],
        counters: tuple[str, ...],
        log: RunLog,
        scalars: Scalars,
    ):
        self.agents_per_world = agents_per_world
        self.names = names
        self.counters = counters
        """The numeric entries of the infos that the log keeps."""
        self.log, self.scalars = log, scalars
        self.returns = np.zeros(slots)
        self.finished: dict[int, tuple[float, dict]] = {}
        """Each slot's return and counters at its episode's end, until its world's ends."""
        self.episodes = 0
        self.global_step = 0
        self.logged = [True] * agents_per_world
        """Which agents of a world the log keeps (``--learners``: those that learn)."""
        self.recent: deque[float] = deque(maxlen=100)
        """The latest returns the log kept since the worlds were made (a curriculum's
        ``until`` reads them)."""

    def after_step(self, reward, terminated, done, infos, acted: int) -> None:
        m = self.agents_per_world
        self.global_step += acted
        self.returns[:] += reward
        for slot in np.flatnonzero(done):
            self.finished[slot] = (self.returns[slot], {k: infos[k][slot] for k in self.counters})
            self.returns[slot] = 0.0
        for w in sorted({int(slot // m) for slot in np.flatnonzero(done)}):
            own = slice(w * m, (w + 1) * m)
            if (done[own] | ~infos["active"][own]).all():  # the world's episode is over
                for j in range(m):
                    episode_return, info = self.finished.pop(w * m + j)
                    if not self.logged[j]:
                        continue
                    self.log.episode(
                        self.global_step, episode_return, info, self.names[j], self.episodes
                    )
                    self.recent.append(float(episode_return))
                    self.scalars.add("charts/episodic_return", episode_return, self.global_step)
                print(f"step={self.global_step} episode={self.episodes} world={w}", flush=True)
                self.episodes += 1

    def restart(self, window: int = 100) -> None:
        """New worlds (a curriculum's next stage): no episode is under way, and none of
        the latest ``window`` returns is kept yet."""
        self.returns[:] = 0.0
        self.finished.clear()
        self.recent = deque(maxlen=window)
