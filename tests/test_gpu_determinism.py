"""``benchmarks/card_command.py determinism``'s comparison of two runs' metrics: what counts as the same run
(timing fields aside, NaN equal to NaN) and where two runs first part."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def determinism():
    return load_script("benchmarks/card_command.py").determinism


def rows(**changes):
    """Three iterations of metrics; ``changes`` maps ``(iteration, field)`` names like ``i2_kl`` to values."""
    out = [
        {"iteration": i, "env_steps": 100.0 * i, "kl": 0.01 * i, "return_mean_policy": math.nan, "wall_time_s": 1.0 * i}
        for i in (1, 2, 3)
    ]
    for name, value in changes.items():
        iteration, field = name.split("_", 1)
        out[int(iteration[1:]) - 1][field] = value
    return out


def test_runs_that_differ_only_in_timing_are_identical(determinism):
    result = determinism.compare(rows(), rows(i1_wall_time_s=9.0, i3_eval_seconds=2.0))
    assert result == {"identical": True, "first_iteration": None, "field": None, "max_rel": 0.0}


def test_the_first_difference_and_the_largest_relative_one_are_found(determinism):
    result = determinism.compare(rows(), rows(i2_kl=0.03, i3_kl=0.06, i3_return_mean_policy=5.0))
    assert result["identical"] is False
    assert (result["first_iteration"], result["field"]) == (2, "kl")
    # 0.02 vs 0.03 is 1/3 and 0.03 vs 0.06 is 1/2; NaN against 5.0 differs but has no size.
    assert result["max_rel"] == pytest.approx(0.5)
    only_nan = determinism.compare(rows(), rows(i3_return_mean_policy=5.0))
    assert (only_nan["identical"], only_nan["first_iteration"], only_nan["max_rel"]) == (False, 3, 0.0)


def test_runs_of_different_lengths_are_refused(determinism):
    with pytest.raises(ValueError):
        determinism.compare(rows(), rows()[:2])
