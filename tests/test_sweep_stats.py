"""``jaxpg.sweep.stats`` against hand-computed values and NumPy: the IQM, the stratified bootstrap
(whose resamples keep each task's runs apart), the probability of improvement, the performance
profile and the normalisation."""

from __future__ import annotations

import numpy as np
import pytest

from jaxpg.sweep import stats


def test_iqm_is_the_mean_of_the_middle_half():
    x = np.array([9.0, 1.0, 5.0, 3.0, 100.0, 4.0, 2.0, -50.0])  # sorted: -50 1 2 3 4 5 9 100
    assert stats.iqm(x) == pytest.approx(np.mean([2.0, 3.0, 4.0, 5.0]))
    # 10 runs: int(2.5) = 2 trimmed from each end, as scipy.stats.trim_mean and rliable do.
    y = np.arange(10.0)
    assert stats.iqm(y) == pytest.approx(np.mean(np.arange(2.0, 8.0)))


def test_summary_points_are_numpy_statistics_of_the_pooled_runs():
    scores = {"a": [1.0, 2.0, 3.0, 4.0, 10.0], "b": [0.5, 0.7, 0.1]}
    pooled = np.concatenate([np.array(v) for v in scores.values()])
    out = stats.summarize(scores)
    assert out["mean"] == pytest.approx(np.mean(pooled))
    assert out["median"] == pytest.approx(np.median(pooled))
    assert out["iqm"] == pytest.approx(np.mean(np.sort(pooled)[2:6]))
    assert out["runs"] == 8
    for name in ("mean", "median", "iqm"):
        assert out[f"{name}_low"] <= out[name] <= out[f"{name}_high"]


def test_bootstrap_is_stratified_over_tasks():
    """Task a's two runs [0, 1] and task b's ten runs of 5: a stratified resample always holds two
    runs of a and ten of b, so its mean is (k + 50) / 12 with k ~ Binomial(2, 1/2) (masses 1/4,
    1/2, 1/4): the 95 % percentile interval is exactly [50/12, 52/12]. Resampling the twelve
    runs together would reach far below (resamples with several zeros)."""
    _, low, high = stats.interval([np.array([0.0, 1.0]), np.full(10, 5.0)], stats._pooled(stats.mean))
    assert (low, high) == (pytest.approx(50 / 12), pytest.approx(52 / 12))


def test_bootstrap_interval_of_a_mean_matches_normal_theory():
    """400 standard normal runs: the 95 % interval of the mean is about +-1.96 / sqrt(400) around
    it; the percentile bootstrap with 5000 resamples is within Monte-Carlo error (a few %) of it."""
    x = np.random.default_rng(0).standard_normal(400)
    point, low, high = stats.interval([x], stats.mean)
    half = 1.96 * np.std(x, ddof=1) / np.sqrt(x.size)
    assert point == pytest.approx(np.mean(x))
    assert high - low == pytest.approx(2 * half, rel=0.1)
    assert (low + high) / 2 == pytest.approx(point, abs=0.1 * half)


def test_constant_scores_give_a_zero_width_interval():
    assert stats.interval([np.full(4, 3.0)], stats.iqm) == (3.0, 3.0, 3.0)


def test_probability_of_improvement_by_hand():
    # [1, 2, 3] against [2, 2]: pairs won 2 (3 > 2 twice), tied 2 (2 = 2), lost 2: (2 + 0.5 * 2) / 6.
    p, low, high = stats.probability_of_improvement({"t": [1.0, 2.0, 3.0]}, {"t": [2.0, 2.0]})
    assert p == pytest.approx(0.5) and low <= p <= high
    # Two tasks, averaged: one always won (1), one always lost (0).
    p, low, high = stats.probability_of_improvement({"a": [3.0, 4.0], "b": [0.0, 0.0]}, {"a": [1.0, 2.0], "b": [1.0]})
    assert (p, low, high) == (0.5, 0.5, 0.5)
    with pytest.raises(ValueError, match="share no task"):
        stats.probability_of_improvement({"a": [1.0]}, {"b": [1.0]})


def test_performance_profile_by_hand():
    scores = {"a": [0.0, 1.0, 2.0, 3.0], "b": [10.0, 10.0]}
    profile = stats.performance_profile(scores, [-1.0, 1.5, 5.0, 20.0])
    points = [p for p, _, _ in profile]
    # Fraction of runs above tau, averaged over the two tasks.
    assert points == pytest.approx([1.0, (0.5 + 1.0) / 2, (0.0 + 1.0) / 2, 0.0])
    for p, low, high in profile:
        assert low <= p <= high


def test_normalize():
    assert stats.normalize(np.array([0.0, 50.0, 100.0]), 0.0, 100.0) == pytest.approx([0.0, 0.5, 1.0])


def fake_sweep(path, task, scores):
    """A finished sweep's ``summary.json`` with the given ``{label: [scores]}``."""
    import json

    runs = [{"label": label, "score": s, "final_return": 0.0} for label, values in scores.items() for s in values]
    path.mkdir()
    (path / "summary.json").write_text(json.dumps({"spec": {"task": task}, "runs": runs}))
    return path


def test_aggregate_normalises_and_pools_tasks(tmp_path, capsys):
    """Two tasks' sweeps: label x scores [0, 100] on a (bounds 0:100 -> [0, 1]) and [50, 50] on b
    (bounds 0:50 -> [1, 1]); label y [0, 0] and [0, 0] -> all 0. Pooled, x's runs are [0, 1, 1, 1]:
    mean 0.75, IQM 1 (one run trimmed from each end). P(x > y): on a, two of the four pairs tie
    (0 against 0) and two are won (100 against 0): 0.75; on b all four are won: 1; averaged 0.875."""
    from jaxpg.sweep import aggregate

    a = fake_sweep(tmp_path / "a", "a", {"x": [0.0, 100.0], "y": [0.0, 0.0]})
    b = fake_sweep(tmp_path / "b", "b", {"x": [50.0, 50.0], "y": [0.0, 0.0], "z": [1.0]})
    out = tmp_path / "out"
    args = [str(a), str(b), "--normalize", "a=0:100", "--normalize", "b=0:50", "--out", str(out)]
    assert aggregate.main([*args, "--compare", "x", "y"]) == 0
    import csv

    rows = {r["label"]: r for r in csv.DictReader((out / "aggregate.csv").open())}
    assert set(rows) == {"x", "y"}  # z is not in both sweeps
    assert float(rows["x"]["mean"]) == pytest.approx(0.75)
    assert float(rows["x"]["iqm"]) == pytest.approx(1.0)
    assert float(rows["y"]["mean"]) == 0.0
    assert "P(x > y) = 0.875" in capsys.readouterr().out
    assert (out / "performance_profiles.png").is_file() and (out / "profiles.csv").is_file()
    assert aggregate.main([str(a), str(b), "--normalize", "a=0:100", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0] == "error: no --normalize bounds for b"
