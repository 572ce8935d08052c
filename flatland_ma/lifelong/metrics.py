"""The metrics of continual RL, from evaluation blocks logged through a life.

Every block evaluates every task; ``p[b, i]`` is the performance on task ``i`` at block
``b``, normalised per task: ``p = (R - random_i) / (reference_i - random_i)``, where
``random_i`` is random play's mean return on the task and ``reference_i`` the final
performance of the reference learner (trained on the task alone), averaged over its seeds.
0 is random play; 1 is what learning the task alone reaches in one segment's steps.

Between blocks performance is taken as linear (``np.interp``); ``start_i``, ``end_i`` are
the first and last agent-steps of task ``i``'s first segment, ``T`` the end of the life.

- average performance: ``A = mean_i p_i(T)`` (Chaudhry et al. 2018; Wołczyk et al. 2021,
  Continual World);
- forgetting of task ``i``: ``F_i = max_{end_i <= t_b < T} p_i(t_b) - p_i(T)``, the best
  performance at a block from the end of its training to before the last block, minus the
  final one (Chaudhry et al. 2018, RWalk; Continual World takes the block at ``end_i``);
  undefined for a task whose first segment ends the life;
- forward transfer of task ``i``: ``FT_i = (AUC_i - AUC_i^ref) / (1 - AUC_i^ref)``, with
  ``AUC_i`` the mean of ``p_i`` over ``[start_i, end_i]`` and ``AUC_i^ref`` that of the
  reference learner over its first ``end_i - start_i`` steps (Continual World); undefined
  when ``AUC_i^ref >= 1``;
- backward transfer: ``BWT = 1/(N-1) sum_{i<N} (p_i(T) - p_i(end_i))`` over the tasks
  but the one trained last (Lopez-Paz and Ranzato 2017, GEM); negative is forgetting.

In the JSON the report writes (``summary_json``), a metric that is undefined (NaN here),
or an interval bound with one seed, is ``null``: the file is strict JSON (RFC 8259), which
has no NaN, so any parser reads it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np

GRID = 101
"""Points at which a learning curve is sampled to average it over a segment."""


def normalise(returns: np.ndarray, random: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Returns (..., tasks) as fractions of the way from random play to the reference."""
    span = np.asarray(reference, float) - np.asarray(random, float)
    if np.any(span <= 0):
        bad = [int(i) for i in np.flatnonzero(span <= 0)]
        raise ValueError(f"tasks {bad}: the reference does not beat random play, no scale")
    return (np.asarray(returns, float) - random) / span


def curve_mean(steps: np.ndarray, values: np.ndarray, start: float, end: float) -> float:
    """The mean over [start, end] of the piecewise-linear curve through (steps, values)."""
    v = np.interp(np.linspace(start, end, GRID), steps, values)
    return float((v.sum() - (v[0] + v[-1]) / 2) / (GRID - 1))  # the trapezoid rule


@dataclass
class Metrics:
    average: float
    forgetting: np.ndarray
    """Per task (NaN where undefined)."""
    forward_transfer: np.ndarray
    """Per task (NaN where undefined)."""
    backward_transfer: float


def first_segments(segments: list, tasks: int) -> list[tuple[int, int]]:
    """Each task's first segment, (start, end)."""
    out: dict[int, tuple[int, int]] = {}
    for task, start, end in segments:
        out.setdefault(int(task), (int(start), int(end)))
    missing = [i for i in range(tasks) if i not in out]
    if missing:
        raise ValueError(f"tasks {missing} are never trained in the stream's segments")
    return [out[i] for i in range(tasks)]


def life_metrics(
    steps: np.ndarray,
    p: np.ndarray,
    segments: list,
    reference: list[tuple[np.ndarray, np.ndarray]] | None = None,
) -> Metrics:
    """The metrics of one life: ``p[b, i]`` normalised performance at ``steps[b]``;
    ``reference[i]`` the reference learner's (steps, p_i) on task ``i`` (for forward
    transfer; NaN without it)."""
    steps, p = np.asarray(steps, float), np.asarray(p, float)
    blocks, tasks = p.shape
    spans = first_segments(segments, tasks)
    final = p[-1]
    last_end = max(int(end) for _, _, end in segments)
    forgetting = np.full(tasks, np.nan)
    forward = np.full(tasks, np.nan)
    for i, (start, end) in enumerate(spans):
        after = (steps >= end) & (np.arange(blocks) < blocks - 1)
        if end < last_end and after.any():
            forgetting[i] = p[after, i].max() - final[i]
        if reference is not None:
            ref_steps, ref_p = reference[i]
            auc_ref = curve_mean(np.asarray(ref_steps, float), ref_p, 0.0, end - start)
            if auc_ref < 1:
                auc = curve_mean(steps, p[:, i], start, end)
                forward[i] = (auc - auc_ref) / (1 - auc_ref)
    earlier = [i for i, (_, end) in enumerate(spans) if end < last_end]
    backward = (
        float(np.mean([final[i] - np.interp(spans[i][1], steps, p[:, i]) for i in earlier]))
        if earlier
        else float("nan")
    )
    return Metrics(float(final.mean()), forgetting, forward, backward)


def interval(values, confidence: float = 0.95) -> tuple[float, float, float]:
    """Mean and Student-t confidence interval over seeds (NaNs dropped); one value: no
    interval (NaN bounds)."""
    from scipy import stats

    x = np.asarray(values, float)
    x = x[~np.isnan(x)]
    if len(x) == 0:
        return float("nan"), float("nan"), float("nan")
    mean = float(x.mean())
    if len(x) == 1:
        return mean, float("nan"), float("nan")
    half = float(stats.t.ppf(0.5 + confidence / 2, len(x) - 1) * x.std(ddof=1) / np.sqrt(len(x)))
    return mean, mean - half, mean + half


def strict(value):
    """``value`` (nested dicts, lists and tuples of numbers and strings) ready for strict
    JSON: every number that is not finite (an undefined metric is NaN) becomes None."""
    if isinstance(value, dict):
        return {str(k): strict(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [strict(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def summary_json(summary: dict) -> str:
    """``summary`` as strict JSON text: no ``NaN`` or ``Infinity`` tokens (``null``)."""
    return json.dumps(strict(summary), indent=1, allow_nan=False)
