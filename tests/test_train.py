"""The training loop: evaluation runs between compiled calls, scans equal single calls, and the
Hopper command line's defaults hold for every batch size it accepts."""

from __future__ import annotations

import dataclasses
import threading
from pathlib import Path

import jax
import numpy as np
import pytest
from script_loader import load_script

import jaxpg.envs as envs
from jaxpg import train as train_lib
from jaxpg.algos import npg
from jaxpg.run.command import planning

ROOT = Path(__file__).resolve().parent.parent
# cg_damping 1.0 bounds the condition number of the Fisher solve, 1 + lambda_max(F) / damping, by ~8
# (lambda_max(F) of this policy is 3.3-7.1 over its first 4 iterations, by power iteration), so that
# programs that sum in another float32 order give steps that agree to ~1e-4 (see the scan test).
CONFIG = npg.Config(
    num_envs=8, horizon=16, eval_envs=2, eval_every=3, eval_horizon=20, value_batch_size=32, cg_damping=1.0
)
TRAINING_KEYS = ("return_stochastic", "kl", "value_loss", "grad_norm", "step_length", "env_steps", "entropy")


@pytest.fixture(scope="module")
def cartpole():
    return envs.make("cartpole")


@pytest.fixture(scope="module")
def state(cartpole):
    return npg.init(jax.random.PRNGKey(0), cartpole, CONFIG)


def run(state, iterations, states=None, **kwargs):
    """``train`` for ``iterations``: its final state and the metrics of every iteration; with a list
    ``states``, a copy of the state after each block is appended to it."""
    rows = []

    def record(ts, metrics, first):
        rows.append(metrics)
        if states is not None:
            states.append(train_lib.own_buffers(ts))  # the next block donates ts

    final = train_lib.train(npg.update, state, iterations, callbacks=[record], **kwargs)
    return final, {k: np.concatenate([m[k] for m in rows]) for k in rows[0]}


def test_evaluation_is_not_compiled_into_update(state):
    """The update's program is the same whatever the evaluation settings: nothing of the
    evaluation rollout is traced into it, and it reports no mean-policy metrics."""
    no_eval = state.replace(config=dataclasses.replace(CONFIG, eval_envs=0, eval_every=1))
    assert str(jax.make_jaxpr(npg.update)(state)) == str(jax.make_jaxpr(npg.update)(no_eval))
    _, metrics = jax.jit(npg.update)(state)
    assert not set(train_lib.EVAL_METRICS) & set(metrics)


def test_train_evaluates_between_calls_at_its_cadence_and_at_the_end(state):
    final, metrics = run(state, 7, block_size=7)
    np.testing.assert_array_equal(np.flatnonzero(metrics["evaluated"]) + 1, [3, 6, 7])
    evaluated = ~np.isnan(metrics["return_mean_policy"])
    np.testing.assert_array_equal(evaluated, metrics["evaluated"] == 1)
    assert np.all(metrics["eval_seconds"][evaluated] > 0) and np.all(metrics["eval_seconds"][~evaluated] == 0)

    # Evaluating changes nothing in training: the same run without evaluation has the same metrics.
    # The evaluations split the block into calls of 3, 3 and 1 iterations; the run without them is
    # split the same way (blocks of 3), so that both run the same compiled programs (the same bits).
    _, plain = run(state, 7, block_size=3, evaluate=None)
    for key in TRAINING_KEYS:
        np.testing.assert_array_equal(metrics[key], plain[key], err_msg=key)
    assert "evaluated" not in plain

    # The logged evaluation is evaluate_state of the state after that iteration.
    after_three, _ = run(state, 3, block_size=3, evaluate=None)
    direct = jax.jit(train_lib.evaluate_state)(after_three)
    assert float(direct["return_mean_policy"]) == metrics["return_mean_policy"][2]
    assert int(final.iteration) == 7

    _, no_final = run(state, 4, block_size=4, final_eval=False)
    np.testing.assert_array_equal(np.flatnonzero(no_final["evaluated"]) + 1, [3])


def test_evaluation_program_is_compiled_once_ahead_and_used_at_every_evaluation(state):
    """``train`` compiles the evaluation on a background thread after its first call and runs that
    program at each evaluation, and in later ``train`` calls: the evaluation is traced once (a
    fallback to the jitted function, e.g. because the state's shapes or shardings differ from the
    example's, would trace it again)."""
    traced_on = []

    def counting_evaluate(ts):
        traced_on.append(threading.current_thread())
        return train_lib.evaluate_state(ts)

    _, metrics = run(state, 7, block_size=7, evaluate=counting_evaluate)
    np.testing.assert_array_equal(np.flatnonzero(metrics["evaluated"]) + 1, [3, 6, 7])
    assert len(traced_on) == 1 and traced_on[0] is not threading.main_thread()
    run(state, 4, block_size=4, evaluate=counting_evaluate)  # a later call reuses the program
    assert len(traced_on) == 1
    _, plain = run(state, 7, block_size=7)
    np.testing.assert_array_equal(metrics["return_mean_policy"], plain["return_mean_policy"])


def params_distance(a, b) -> float:
    """Euclidean distance between two parameter pytrees of the same structure."""
    pairs = zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True)
    return float(np.sqrt(sum(np.sum(np.square(np.asarray(x) - np.asarray(y))) for x, y in pairs)))


def test_before_first_call_runs_once_between_compiling_and_running_the_first_block(state):
    """``before_first_call`` (where the command line waits for MuJoCo Warp's kernels) is called
    once, after the first block's program is compiled and before any block has run, and the run
    is the same as one without it: the call after it runs the program compiled ahead."""
    calls = []
    rows = []

    def hook():
        calls.append(len(rows))

    def record(ts, metrics, first):
        rows.append(metrics)

    final = train_lib.train(
        npg.update, state, 6, block_size=3, evaluate=None, callbacks=[record], before_first_call=hook
    )
    assert calls == [0] and len(rows) == 2
    plain, _ = run(state, 6, block_size=3, evaluate=None)
    for a, b in zip(jax.tree.leaves(final.params), jax.tree.leaves(plain.params), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_scan_of_k_iterations_gives_the_metrics_of_k_single_calls(state):
    """Four iterations as one compiled scan or as four calls of a one-iteration program: the same
    training, up to what float32 allows between two programs.

    The scan's body and the one-iteration program are different programs, which the compiler may
    fuse and order differently (another CPU, vector width or JAX version), so they may differ in
    the last bits:
    - Integer state exactly: RNG key, iteration counter, env step and failure counts.
    - One step from the same state: the scan started from the state before each single call agrees
      with that call on its first iteration. The rollout, advantages, gradient and value fit are
      float32 sums of at most a few thousand terms (relative difference <= ~1e-5), and the conjugate
      gradient amplifies that by at most the condition number ~8 of ``CONFIG``'s Fisher solve, so
      every metric agrees to rtol 1e-3 (atol 1e-6 for those near zero); the CG residual is itself
      round-off and is left out.
    - The scan's own later iterations step from parameters that may differ in the last bits, where
      an episode can end a step earlier or later, so no float tolerance follows from the
      computation. What a scan that threads its state wrongly (stale parameters, a repeated batch)
      would break is that its final parameters lie within a tenth of the distance that the four
      iterations moved them from the single calls' final parameters.
    Measured (AMD EPYC, JAX 0.10, also with ``--xla_cpu_max_isa=SSE4_2``): bit-identical there.
    """
    scanned, fused = run(state, 4, block_size=4, evaluate=None)
    single_states = []
    single, one_by_one = run(state, 4, block_size=1, evaluate=None, states=single_states)
    np.testing.assert_array_equal(np.asarray(scanned.key), np.asarray(single.key))
    assert int(scanned.iteration) == int(single.iteration) == 4
    scan4 = train_lib.compiled_block(npg.update, 4, False)
    worst = {}
    for k, start in enumerate([state, *single_states[:-1]]):
        _, from_here = scan4(train_lib.own_buffers(start))
        for key in one_by_one:
            if key == "cg_residual":
                continue
            got, want = np.asarray(from_here[key][0]), one_by_one[key][k]
            worst[key] = max(worst.get(key, 0.0), float(np.abs(got - want) / max(abs(want), 1e-6)))
            np.testing.assert_allclose(got, want, rtol=1e-3, atol=1e-6, err_msg=f"{key} iteration {k + 1}")
    for key in ("env_steps", "update_rejected", "consecutive_failures"):
        np.testing.assert_array_equal(fused[key], one_by_one[key], err_msg=key)

    gap, moved = params_distance(scanned.params, single.params), params_distance(single.params, state.params)
    print(f"\nscan vs single calls: one step {max(worst.values()):.1e} relative, final parameters apart by")
    print(f"{gap / moved:.1e} of their move")
    assert gap < 0.1 * moved, (gap, moved)


def _hopper_experiment():
    return load_script("experiments/hopper.py").EXPERIMENT


@pytest.mark.parametrize("num_envs", [64, 256, 1024, 4096, 65536])
def test_hopper_command_line_defaults_hold_from_64_to_65536_envs(num_envs, tmp_path):
    experiment = _hopper_experiment()
    plan = planning.plan(["--num-envs", str(num_envs), "--run-dir", str(tmp_path / "run")], experiment)
    config = plan.config
    assert (plan.run.algo, config.num_envs, plan.run.iterations) == ("npg", num_envs, 120)
    # The value fit takes the same number of minibatch steps at every batch size, on minibatches
    # that stop growing above the card's 256 x 64 samples.
    assert config.value_samples_per_epoch // config.value_minibatch_size == config.value_minibatches == 16
    assert config.value_minibatch_size == min(num_envs * config.horizon, 16384) // 16
    # The natural gradient's Fisher-vector products likewise stop growing with the batch.
    assert config.fisher_samples == 16384
    assert config.normalize_value_targets
    assert config.normalize_observations and config.kl_delta == npg.PRESETS["hopper"]["kl_delta"]
    # Evaluation costs little: a handful of evaluations, on block boundaries.
    assert plan.run.iterations // config.eval_every <= 2
    assert config.eval_every % plan.run.block_size == 0
    assert not (tmp_path / "run").exists()  # planning writes nothing


def test_eval_cost_benchmark_times_early_stop_and_full_evaluations_alike():
    """``benchmarks/throughput.py eval`` on a fresh pendulum policy (its episodes end within a few
    steps): the evaluation with the early stop and the full one reach the same returns, and the
    row says how long the episodes were."""
    bench = load_script("benchmarks/throughput.py").evaluation
    task, kwargs, policy, params, stats = bench.policy_to_evaluate(None, "inverted_pendulum")
    row = bench.eval_measure(task, kwargs, policy, params, stats, "jax", "default", episodes=2, repeats=1)
    assert row["horizon"] == 1000 and row["episodes"] == 2
    assert 1 <= row["length_mean"] <= row["length_max"] < 50
    assert row["eval_s"] > 0 and row["eval_full_s"] > 0 and np.isfinite(row["return_mean"])
    np.testing.assert_allclose(row["return_mean"], row["return_full_mean"], rtol=1e-6)
