"""The statistics of an evaluation, as rliable (Agarwal et al., 2021) and MARL-eval report
them: scores normalised per task, the interquartile mean over every run of every task,
and percentile intervals from a bootstrap that resamples runs within each task; for
competitive tasks, Elo ratings from a cross-play matrix.

The interquartile mean is SciPy's ``trim_mean`` with a quarter cut from each end, which is
rliable's own definition, computed here as ``trim_mean`` computes it (``int(n / 4)`` values
cut from each end of the sorted scores) without its per-call overhead, which dominated a
bootstrap's thousands of calls; rliable itself is not a dependency (it pulls statsmodels,
arch and seaborn for these few lines).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np


def normalise(score, random: float, best: float):
    """``score`` on the task's scale where random play scores 0 and the best scripted
    policy 1; ``ValueError`` if they do not differ."""
    if not best > random:
        raise ValueError(
            f"the best scripted policy ({best:g}) must score above random play ({random:g})"
        )
    return (np.asarray(score, np.float64) - random) / (best - random)


def iqm(scores) -> float:
    """The interquartile mean: the mean of the middle half of the scores (a quarter cut
    from each end, as ``scipy.stats.trim_mean``)."""
    values = np.sort(np.asarray(scores, np.float64).ravel())
    if values.size == 0:
        raise ValueError("no scores")
    cut = values.size // 4
    return float(values[cut : values.size - cut].mean())


def stratified_bootstrap(
    runs: Sequence[Sequence[float]],
    statistic: Callable = iqm,
    reps: int = 2000,
    level: float = 0.95,
    seed: int = 0,
) -> tuple[float, float, float]:
    """``statistic`` of every run of every task pooled, and its ``level`` percentile
    interval over ``reps`` resamples that draw, for each task, as many runs as it has from
    its own runs with replacement. Returns (point, low, high)."""
    tasks = [np.asarray(r, np.float64).ravel() for r in runs]
    if not tasks or any(t.size == 0 for t in tasks):
        raise ValueError("every task needs at least one run")
    rng = np.random.default_rng(seed)
    point = statistic(np.concatenate(tasks))
    samples = np.empty(reps)
    for k in range(reps):
        samples[k] = statistic(np.concatenate([t[rng.integers(0, t.size, t.size)] for t in tasks]))
    tail = (1.0 - level) / 2.0 * 100.0
    low, high = np.percentile(samples, [tail, 100.0 - tail])
    return float(point), float(low), float(high)


def elo(scores, start: float = 1000.0, iterations: int = 1000) -> np.ndarray:
    """Elo ratings from a cross-play matrix: ``scores[i, j]`` in [0, 1] is how often policy
    i beat policy j (a draw counts a half; the diagonal is not read). The ratings are the
    maximum-likelihood fit of the Elo (Bradley-Terry) model, in which i beats j with odds
    ``10 ** ((r_i - r_j) / 400)``, to each pair's results (i against j and j against i
    averaged), centred on ``start``. Results are kept within [1%, 99%], so that a policy
    that always wins gets a finite rating."""
    scores = np.asarray(scores, np.float64)
    n = scores.shape[0]
    if scores.ndim != 2 or scores.shape != (n, n) or n < 2:
        raise ValueError(
            f"a cross-play matrix is square, of two policies or more, not {scores.shape}"
        )
    if not np.isfinite(scores).all() or (scores < 0).any() or (scores > 1).any():
        raise ValueError("cross-play results are fractions of games won, in [0, 1]")
    wins = np.clip((scores + 1.0 - scores.T) / 2.0, 0.01, 0.99)
    np.fill_diagonal(wins, 0.0)
    strength = np.ones(n)
    for _ in range(iterations):  # the MM algorithm (Hunter, 2004): each step raises the fit
        pair = strength[:, None] + strength[None, :]
        np.fill_diagonal(pair, np.inf)
        strength = wins.sum(axis=1) / (1.0 / pair).sum(axis=1)
        strength /= np.exp(np.log(strength).mean())
    ratings = 400.0 * np.log10(strength)
    return ratings - ratings.mean() + start
