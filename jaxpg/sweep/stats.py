"""The statistics the field reports for few-run deep RL (Agarwal et al., *Deep Reinforcement
Learning at the Edge of the Statistical Precipice*, NeurIPS 2021): mean, median and interquartile
mean (IQM) of run scores with 95 % stratified-bootstrap confidence intervals, normalised scores
across tasks, performance profiles and the probability of improvement.

The bootstrap is SciPy's (``scipy.stats.bootstrap``, percentile intervals, as the paper's library
``rliable`` computes them). Its samples are the tasks' score arrays, given with ``paired=False``:
SciPy then resamples each sample on its own, with replacement, to its own size, which is exactly
the stratified bootstrap (runs resampled within each task, never across). With one task it is the
plain bootstrap over runs. ``RESAMPLES`` resamples, drawn from a seeded generator: the same
scores always give the same intervals.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from scipy import stats as scipy_stats

RESAMPLES = 5000
CONFIDENCE = 0.95


def iqm(x: np.ndarray, axis: int = -1) -> np.ndarray:
    """Interquartile mean: the mean of the middle 50 % of ``x`` along ``axis`` (25 % trimmed from
    each end, ``scipy.stats.trim_mean``)."""
    return scipy_stats.trim_mean(x, 0.25, axis=axis)


def mean(x: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.mean(x, axis=axis)


def median(x: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.median(x, axis=axis)


AGGREGATES: dict[str, Callable[..., np.ndarray]] = {"mean": mean, "median": median, "iqm": iqm}


def _pooled(metric: Callable[..., np.ndarray]) -> Callable[..., np.ndarray]:
    """``metric`` of the tasks' samples pooled along the last axis (scores already normalised)."""

    def statistic(*samples: np.ndarray, axis: int = -1) -> np.ndarray:
        return metric(np.concatenate(samples, axis=axis), axis=axis)

    return statistic


def interval(
    samples: Sequence[np.ndarray], statistic: Callable[..., np.ndarray], seed: int = 0
) -> tuple[float, float, float]:
    """``(point, low, high)``: ``statistic(*samples)`` and its 95 % stratified-bootstrap percentile
    interval (module docstring). Samples of one run each, or of identical runs, give a zero-width
    interval at the point."""
    samples = [np.asarray(s, np.float64).ravel() for s in samples]
    point = float(statistic(*samples, axis=-1))
    if all(s.size < 2 or np.all(s == s[0]) for s in samples):
        return point, point, point
    # A sample of one run resamples to itself: SciPy takes only the others, and the statistic
    # gets the single runs back, broadcast over the resamples.
    single = {i: s for i, s in enumerate(samples) if s.size < 2}
    free = [s for s in samples if s.size >= 2]

    def with_single(*resampled: np.ndarray, axis: int = -1) -> np.ndarray:
        batch = resampled[0].shape[:-1]
        rest = iter(resampled)
        full = [
            np.broadcast_to(single[i], batch + single[i].shape) if i in single else next(rest)
            for i in range(len(samples))
        ]
        return statistic(*full, axis=axis)

    options = dict(
        paired=False, vectorized=True, n_resamples=RESAMPLES, confidence_level=CONFIDENCE, method="percentile"
    )
    try:
        result = scipy_stats.bootstrap(tuple(free), with_single, rng=np.random.default_rng(seed), **options)
    except TypeError:  # SciPy before 1.15 names the generator random_state
        result = scipy_stats.bootstrap(tuple(free), with_single, random_state=np.random.default_rng(seed), **options)
    return point, float(result.confidence_interval.low), float(result.confidence_interval.high)


def summarize(scores_by_task: Mapping[str, Sequence[float]], seed: int = 0) -> dict[str, float]:
    """Mean, median and IQM of the runs' (normalised) scores over all tasks, each with its
    interval: ``{"mean": .., "mean_low": .., "mean_high": .., "median": .., ..., "runs": n}``."""
    samples = [np.asarray(v, np.float64) for v in scores_by_task.values()]
    out: dict[str, float] = {"runs": float(sum(s.size for s in samples))}
    for name, metric in AGGREGATES.items():
        point, low, high = interval(samples, _pooled(metric), seed)
        out.update({name: point, f"{name}_low": low, f"{name}_high": high})
    return out


def normalize(scores: np.ndarray, low: float, high: float) -> np.ndarray:
    """``(scores - low) / (high - low)``: 0 at ``low`` (e.g. a random policy), 1 at ``high`` (a
    reference score)."""
    return (np.asarray(scores, np.float64) - low) / (high - low)


def performance_profile(
    scores_by_task: Mapping[str, Sequence[float]], thresholds: Sequence[float], seed: int = 0
) -> list[tuple[float, float, float]]:
    """For each threshold ``tau``: the fraction of runs scoring above ``tau``, averaged over tasks
    (the run-score distribution), with its stratified-bootstrap interval: ``[(point, low, high)]``."""
    samples = [np.asarray(v, np.float64) for v in scores_by_task.values()]
    out = []
    for tau in thresholds:

        def above(*resampled: np.ndarray, axis: int = -1, tau: float = tau) -> np.ndarray:
            return np.mean([np.mean(s > tau, axis=axis) for s in resampled], axis=0)

        out.append(interval(samples, above, seed))
    return out


def probability_of_improvement(
    x_by_task: Mapping[str, Sequence[float]], y_by_task: Mapping[str, Sequence[float]], seed: int = 0
) -> tuple[float, float, float]:
    """``P(X > Y)``: per task, the probability that a run of configuration ``X`` scores above a
    run of ``Y`` (ties count one half: the Mann-Whitney U statistic over ``m n``), averaged over
    the tasks both have; with its stratified-bootstrap interval (each task's ``X`` and ``Y`` runs
    resampled on their own)."""
    tasks = [t for t in x_by_task if t in y_by_task]
    if not tasks:
        raise ValueError("the two configurations share no task")
    samples = []
    for t in tasks:
        samples += [np.asarray(x_by_task[t], np.float64), np.asarray(y_by_task[t], np.float64)]

    def statistic(*resampled: np.ndarray, axis: int = -1) -> np.ndarray:
        per_task = []
        for x, y in zip(resampled[::2], resampled[1::2], strict=True):
            greater = np.mean(x[..., :, None] > y[..., None, :], axis=(-2, -1))
            ties = np.mean(x[..., :, None] == y[..., None, :], axis=(-2, -1))
            per_task.append(greater + 0.5 * ties)
        return np.mean(per_task, axis=0)

    return interval(samples, statistic, seed)
