"""The host's work between blocks stays small for long runs of many seeds: the curves are kept in
memory (never re-read from ``metrics.jsonl``) and redrawn at most every ``PLOT_EVERY_S`` seconds
and at the end; a long run's default checkpoint period keeps it to about 20 checkpoints; the ETA
counts the host's work. No JAX program is compiled here."""

from __future__ import annotations

import json
import types

import numpy as np
import pytest

from jaxpg.run.command.planning import default_checkpoint_every
from jaxpg.run.outputs import metrics_log, plotting
from jaxpg.run.training import callbacks


@pytest.mark.parametrize(
    ("iterations", "log_every", "expected"),
    [(120, 10, 50), (1000, 10, 50), (1020, 10, 60), (1953, 10, 100), (12500, 10, 630), (12500, 7, 630), (99, 3, 50)],
)
def test_a_long_runs_default_checkpoint_period_is_a_twentieth_of_it(iterations, log_every, expected):
    every = default_checkpoint_every(50, iterations, log_every)
    assert every == expected
    assert every == 50 or every % log_every == 0


def block(first, returns, task_scores=None):
    """A block of metrics ``[n, num_seeds]`` starting at 0-based iteration ``first``."""
    returns = np.asarray(returns, np.float64)
    out = {"return_stochastic": returns, "kl": np.zeros_like(returns)}
    if task_scores is not None:
        out["task_score_mean_policy"] = np.asarray(task_scores, np.float64)
    return out


def test_the_curves_kept_in_memory_are_those_read_from_metrics_jsonl():
    """``CurveHistory`` built block by block, and continued after a resume from the records of
    ``metrics.jsonl``, holds what ``seed_curves`` reads from all records."""
    seeds = [4, 7]
    blocks = [
        (0, block(0, [[1.0, 2.0], [np.nan, 3.0]])),
        (2, block(2, [[4.0, 5.0], [6.0, np.nan]], task_scores=[[0.5, np.nan], [0.7, 0.8]])),
        (4, block(4, [[7.0, 8.0]])),
    ]
    records = [r for first, m in blocks for r in metrics_log.block_records(m, first, seeds, [0.0] * len(m["kl"]))]
    live = plotting.CurveHistory()
    for first, m in blocks:
        live.add_block(m, first)
    resumed = plotting.CurveHistory.from_records(records[:8])  # iterations 1-4, then 5 live
    resumed.add_block(blocks[2][1], 4)
    for key in plotting.CURVE_KEYS:
        iterations, values = plotting.seed_curves(records, key)
        for history in (live, resumed):
            got_iterations, got_values = history.curve(key)
            np.testing.assert_array_equal(got_iterations, iterations)
            np.testing.assert_array_equal(got_values, values)
    assert live.measured("task_score_mean_policy") and not live.measured("return_mean_policy")


class FakeCheckpointer:
    def __init__(self):
        self.saved = []

    def save(self, step, ts, score, metrics, info):
        self.saved.append(step)


def fake_plan(tmp_path, iterations=100, checkpoint_every=10):
    run = types.SimpleNamespace(
        iterations=iterations, checkpoint_every=checkpoint_every, task="t", algo="a", seeds=[0], log_every=10
    )
    return types.SimpleNamespace(
        run=run,
        run_dir=tmp_path,
        config=types.SimpleNamespace(eval_envs=0),
        env=types.SimpleNamespace(task_score_name=None),
        time_limit_s=None,
        start=0,
    )


def test_curves_are_redrawn_at_most_every_plot_every_s_and_always_at_the_end(tmp_path, monkeypatch):
    drawn = []
    monkeypatch.setattr(plotting, "plot_run", lambda run_dir, task_score_name=None, history=None: drawn.append(history))
    clock = [0.0]
    monkeypatch.setattr(callbacks.time, "perf_counter", lambda: clock[0])
    history = plotting.CurveHistory()
    saver = callbacks.Checkpoints(fake_plan(tmp_path), FakeCheckpointer(), progress=None, history=history, primary=True)
    metrics = block(0, [[1.0]] * 10)
    for first in range(0, 40, 10):  # checkpoints at 10, 20, 30, 40 in the first second: not drawn yet
        clock[0] += 0.25
        saver(None, metrics, first)
    assert saver.checkpoints.saved == [10, 20, 30, 40] and not drawn
    clock[0] += callbacks.PLOT_EVERY_S
    saver(None, metrics, 40)  # iteration 50, PLOT_EVERY_S after the start: drawn
    assert len(drawn) == 1 and drawn[0] is history
    saver(None, metrics, 50)  # iteration 60, at once: not redrawn ...
    assert len(drawn) == 1
    saver.save_if_behind(None, metrics, 50)  # ... until a time limit or an interrupt stops the run there
    assert saver.checkpoints.saved == [10, 20, 30, 40, 50, 60] and len(drawn) == 2
    saver(None, metrics, 90)  # the last iteration (100): always redrawn
    assert saver.checkpoints.saved[-1] == 100 and len(drawn) == 3

    # A run shorter than PLOT_EVERY_S draws its curves once, at the end.
    drawn.clear()
    short = callbacks.Checkpoints(fake_plan(tmp_path, iterations=20), FakeCheckpointer(), progress=None, primary=True)
    short(None, metrics, 0)
    short(None, metrics, 10)
    assert short.checkpoints.saved == [10, 20] and len(drawn) == 1


def test_the_eta_counts_the_hosts_work_between_blocks(tmp_path, monkeypatch):
    """Blocks of 10 iterations taking 1 s to train and 3 s of host work: 4 s per block left."""
    clock = [0.0]
    monkeypatch.setattr(callbacks.time, "perf_counter", lambda: clock[0])
    plan = fake_plan(tmp_path, iterations=100)
    plan.config = types.SimpleNamespace(samples_per_iteration=8, eval_envs=0)
    timer = callbacks.BlockClock(plan, wall_offset=0.0)
    metrics = block(0, [[1.0]] * 10)
    for first in range(0, 30, 10):
        clock[0] += 1.0
        timer.start_block(None, metrics, first)
        clock[0] += 3.0
        timer.end_host_work(None, metrics, first)
    assert timer.eta(30) == pytest.approx(7 * 4.0)
    assert timer.steps_per_s == pytest.approx(80.0)  # the training rate leaves the host's work out


def test_the_host_work_benchmark_times_each_kind_of_work(tmp_path, capsys):
    """``benchmarks/throughput.py host`` at tiny sizes: a row per kind of work, and the JSON of them."""
    from script_loader import load_script

    throughput = load_script("benchmarks/throughput.py").host
    out = tmp_path / "host.json"
    throughput.host_main(["--seeds", "2", "--keys", "8", "--iterations", "40", "--repeats", "1", "--json", str(out)])
    printed = capsys.readouterr().out
    for work in ("records", "per_scalar", "curves", "reread"):
        assert f"| {work} | " in printed
    rows = json.loads(out.read_text())["rows"]
    assert [r["work"] for r in rows] == ["records", "per_scalar", "curves", "reread"]
    assert all(r["seconds"] > 0 for r in rows)
