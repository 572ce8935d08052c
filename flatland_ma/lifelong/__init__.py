"""Lifelong learning: task streams (``scenarios/streams/``), the envs that live one life
through them (PettingZoo parallel and AEC, Gymnasium, batched), the never-ending drifting
world, and the metrics of continual RL behind ``flatland-ma lifelong report``."""

from __future__ import annotations

from flatland_ma.lifelong.batched import StreamBatchedEnv, task_batched
from flatland_ma.lifelong.envs import StreamGymEnv, StreamParallelEnv, stream_aec_env, task_env
from flatland_ma.lifelong.streams import Stream, StreamSpec, list_streams, load_stream

__all__ = [
    "Stream",
    "StreamBatchedEnv",
    "StreamGymEnv",
    "StreamParallelEnv",
    "StreamSpec",
    "list_streams",
    "load_stream",
    "stream_aec_env",
    "task_batched",
    "task_env",
]
