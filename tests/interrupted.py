"""A ``baselines.ppo`` run stopped part-way, as a killed process would leave it: its
periodic checkpoints and its partial log on disk. Used by the resume and curriculum tests."""

from __future__ import annotations

import pytest


class Interrupted(Exception):
    pass


def stopped_at(args, monkeypatch, update: int) -> None:
    """Run ``baselines.ppo`` with ``args`` until update ``update`` begins, then stop it."""
    from baselines import ppo

    iterate = ppo.Training.iterate

    def stop_at(self, iteration, start):
        if iteration == update:
            raise Interrupted
        iterate(self, iteration, start)

    with monkeypatch.context() as patch:
        patch.setattr(ppo.Training, "iterate", stop_at)
        with pytest.raises(Interrupted):
            ppo.main(args)
