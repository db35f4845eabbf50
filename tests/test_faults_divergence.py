"""Divergence: a block whose state or metrics no healthy run has stops the run before it is
checkpointed (``jaxpg.run.training.divergence``), and ``--from-step N`` resumes from an earlier
checkpoint. The checks are fed hand-made metrics and states (nothing compiled)."""

from __future__ import annotations

import json
import math
import types
from pathlib import Path

import numpy as np
import pytest

from jaxpg import train
from jaxpg.run.command import command_line, main, planning
from jaxpg.run.outputs import metrics_log
from jaxpg.run.rundir import layout, replacing, run_lock
from jaxpg.run.training import divergence

SAMPLES = 128  # samples one seed draws per iteration in these blocks


def block(n: int = 2, seeds: int | None = None, **values: list) -> dict[str, np.ndarray]:
    """A block of ``n`` healthy iterations' metrics, with ``values`` (per iteration) put in."""
    shape = (n,) if seeds is None else (n, seeds)
    metrics = {
        "kl": np.full(shape, 0.01),
        "entropy": np.full(shape, 1.42),
        "update_rejected": np.zeros(shape),
        "nonfinite": np.zeros(shape),
        "return_mean_policy": np.full(shape, np.nan),  # not evaluated: NaN is no sign of divergence
    }
    for key, column in values.items():
        metrics[key] = np.asarray(column, np.float64).reshape(shape)
    return metrics


def state(log_std=(0.0,), weight=0.5, value=0.1, seeds: int | None = None):
    """A stand-in ``TrainState``: the fields the state check reads (Gaussian policy, MLP, stats)."""

    def arr(x):
        a = np.asarray(x, np.float32)
        return a if seeds is None else np.broadcast_to(a, (seeds, *a.shape)).copy()

    return types.SimpleNamespace(
        params={"log_std": arr(log_std), "mean": {"w": arr([[weight, -weight]])}},
        value_params={"w": arr([value])},
        obs_stats={"mean": arr([0.0, 0.0]), "count": np.int32(3)},
    )


HEALTHY = [
    ("healthy", block()),
    ("not evaluated (NaN eval metrics)", block(return_mean_policy=[math.nan, math.nan])),
    ("a rolled-back update with a huge or NaN KL", block(kl=[5110.0, math.nan], update_rejected=[1, 1])),
    ("some non-finite samples", block(nonfinite=[SAMPLES - 1, 3])),
]


@pytest.mark.parametrize("metrics", [m for _, m in HEALTHY], ids=[name for name, _ in HEALTHY])
def test_healthy_blocks_are_not_divergence(metrics):
    assert divergence.metrics_problem(metrics, 10, SAMPLES, action_size=1) is None


DIVERGED = [
    ("accepted KL 5110", block(kl=[0.01, 5110.0]), 12, 0, "mean KL of an accepted update is 5110 nats"),
    ("accepted KL inf", block(kl=[math.inf, 0.01]), 11, 0, "mean KL of an accepted update is inf"),
    ("entropy nan", block(entropy=[0.1, math.nan]), 12, 0, "entropy is nan"),
    ("entropy of log-std 5110", block(entropy=[5111.4, 1.0]), 11, 0, "a log-std beyond +-20"),
    ("every sample non-finite", block(nonfinite=[0, SAMPLES]), 12, 0, "every one of its 128 samples"),
    ("second seed", block(seeds=2, kl=[[0.01, 0.01], [0.01, 2e3]]), 12, 1, "mean KL"),
]


@pytest.mark.parametrize(
    ("metrics", "iteration", "seed", "text"), [d[1:] for d in DIVERGED], ids=[d[0] for d in DIVERGED]
)
def test_diverged_metrics_name_the_iteration_seed_and_cause(metrics, iteration, seed, text):
    found = divergence.metrics_problem(metrics, 10, SAMPLES, action_size=1)
    assert found is not None and found[:2] == (iteration, seed) and text in found[2], found


def test_the_entropy_bound_is_per_action_dimension():
    """A 17-dimensional Gaussian of log-std 1 has entropy 17 * (1 + 1.42) = 41: healthy."""
    assert divergence.metrics_problem(block(entropy=[41.1, 41.1]), 0, SAMPLES, action_size=17) is None
    assert divergence.metrics_problem(block(entropy=[41.1, 41.1]), 0, SAMPLES, action_size=1) is not None


@pytest.mark.parametrize(
    ("ts", "seed", "text"),
    [
        (state(log_std=(5110.0,)), 0, "log-std reached 5110"),
        (state(log_std=(-25.0,)), 0, "log-std reached -25"),
        (state(weight=3e6), 0, "a policy parameter reached 3e+06"),
        (state(value=math.nan), 0, "value parameters are not finite"),
        (state(weight=math.inf), 0, "policy parameters are not finite"),
    ],
)
def test_diverged_states_are_caught(ts, seed, text):
    found = divergence.state_problem(ts, seeds=False)
    assert found is not None and found[0] == seed and text in found[1], found


def test_a_healthy_state_and_the_seed_axis():
    assert divergence.state_problem(state(log_std=(-1.0, 2.0)), seeds=False) is None
    ts = state(seeds=3)
    ts.params["log_std"][2] = 40.0
    assert divergence.state_problem(ts, seeds=True) == (2, "its policy's log-std reached 40, beyond +-20")


def guard_for(last_saved: int, seeds=(0,)):
    plan = types.SimpleNamespace(
        run=types.SimpleNamespace(seeds=list(seeds), vmap_seeds=len(seeds) > 1),
        config=types.SimpleNamespace(samples_per_iteration=SAMPLES),
        env=types.SimpleNamespace(action_size=1),
    )
    return divergence.guard_divergence(plan, types.SimpleNamespace(last_saved=last_saved))


def test_the_guard_stops_before_the_checkpoint_and_names_the_last_good_one():
    """The callback raises ``TrainingDiverged`` (one line): the session reports it as one
    ``error:`` line, and the ``Checkpoints`` callback after it never saves the diverged state."""
    guard = guard_for(last_saved=8, seeds=(7,))
    guard(state(), block(), 8)  # healthy: nothing happens
    with pytest.raises(train.TrainingDiverged) as caught:
        guard(state(log_std=(5110.0,)), block(), 8)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith("training diverged at iteration 10 (seed 7): its policy's log-std reached 5110")
    assert "the last good checkpoint, 8, is kept" in message and "--from-step N" in message


def test_the_guard_comes_before_the_checkpoint_in_the_host_callbacks():
    """Order matters: a diverged block must raise before ``Checkpoints`` runs."""
    import inspect

    from jaxpg.run.training import callbacks

    source = inspect.getsource(callbacks.host_callbacks)
    assert source.index("guard_divergence(plan_, saving)") < source.index("        saving,")


# --------------------------------------------------------------------------- --from-step


def test_from_step_continues_from_an_earlier_checkpoint(run_copy, capsys):
    """``--resume RUN --from-step 2`` plans from checkpoint 2; once the directory is locked the
    later checkpoint 4 and the metrics after iteration 2 are deleted, with one ``note:`` line."""
    plan = planning.plan(["--resume", str(run_copy), "--from-step", "2"], command_line.Experiment())
    assert plan.start == 2 and plan.later_checkpoints == [4]
    assert (run_copy / layout.CHECKPOINT_DIR / "4").is_dir()  # planning writes nothing
    lock = run_lock.RunLock(run_copy)
    try:
        replacing.prepare_run_dir(plan, lock)
    finally:
        lock.release()
    err = capsys.readouterr().err
    assert "note: --from-step 2: deleted the later checkpoint 4 and the metrics after iteration 2" in err
    assert sorted(p.name for p in (run_copy / layout.CHECKPOINT_DIR).iterdir()) == ["2"]
    assert [r["iteration"] for r in metrics_log.read_metrics(run_copy)] == [1, 2]
    assert json.loads((run_copy / layout.CONFIG_FILE).read_text())["info"]["resumes"][-1]["from_iteration"] == 2


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--from-step", "3"], "--from-step 3: "),
        (["--from-step", "2", "--env", "cartpole"], "--from-step N goes with --resume"),
    ],
)
def test_bad_from_steps_are_one_line(argv, message, run_copy, capsys):
    before = sorted(str(p) for p in Path(run_copy).rglob("*"))
    if "--env" not in argv:
        argv = ["--resume", str(run_copy), *argv]
    assert main.main(argv) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], lines
    if "--env" not in argv:
        assert "its checkpoints: 2, 4" in lines[0]
    assert sorted(str(p) for p in Path(run_copy).rglob("*")) == before


# --------------------------------------------------------------------------- non-finite metrics in metrics.jsonl


def test_a_measured_nan_is_not_written_as_not_measured():
    """``null`` means "not measured" (no evaluation, no episode ended); a measured value that is not
    finite is written as "nan" / "inf" / "-inf", which ``float`` reads back."""
    metrics = {
        "kl": np.array([math.nan, math.inf]),
        "entropy": np.array([-math.inf, 1.0]),
        "evaluated": np.array([0.0, 1.0]),
        "return_mean_policy": np.array([math.nan, math.nan]),
        "episodes": np.array([0.0, 2.0]),
        "return_stochastic": np.array([math.nan, 5.0]),
    }
    first, second = metrics_log.block_records(metrics, 0, [0], [1.0, 2.0])
    assert (first["kl"], second["kl"], first["entropy"]) == ("nan", "inf", "-inf")
    assert first["return_mean_policy"] is None and second["return_mean_policy"] == "nan"
    assert first["return_stochastic"] is None and second["return_stochastic"] == 5.0
    line = json.loads(json.dumps(first))  # a JSON line as metrics.jsonl holds it
    assert math.isnan(float(line["kl"])) and float(line["entropy"]) == -math.inf
    from jaxpg.run.outputs import plotting

    _, values = plotting.seed_curves([first, second], "return_mean_policy")
    assert np.isnan(values).all()


# --------------------------------------------------------------------------- end to end


def test_a_resume_that_diverges_keeps_every_good_checkpoint(tmp_path, capsys):
    """The reported case: a run whose settings make one huge update (``kl_delta`` 1e9 with the KL
    guard off, edited into ``config.json``: valid values) resumed from its checkpoint 2. It stops
    at iteration 3 with one ``error:`` line naming checkpoint 2, exit 1; checkpoint 2 is still the
    latest (before: the broken state was checkpointed and good ones rotated out), and a retry
    does the same."""
    import test_cli

    from jaxpg.run.checkpoints.checkpointer import Checkpointer

    run_dir = tmp_path / "run"
    assert main.main([*test_cli.TINY, "--iterations", "2", "--keep-checkpoints", "1", "--run-dir", str(run_dir)]) == 0
    config = json.loads((run_dir / layout.CONFIG_FILE).read_text())
    config["config"].update(kl_delta=1e9, max_update_kl=0.0)
    (run_dir / layout.CONFIG_FILE).write_text(json.dumps(config))
    capsys.readouterr()
    for _ in range(2):
        assert main.main(["--resume", str(run_dir), "--iterations", "6"]) == 1
        errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error:")]
        assert len(errors) == 1, errors
        assert (
            errors[0].startswith("error: training diverged at iteration 3 (seed 0): ") and "checkpoint, 2," in errors[0]
        )
        checkpoints = Checkpointer(run_dir / layout.CHECKPOINT_DIR, keep=None)
        assert checkpoints.steps() == [2]
        checkpoints.close()
