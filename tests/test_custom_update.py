"""A custom NPG update assembled from the phase functions (notebook 03, section 1) is NPG itself
when its advantage estimator is GAE, and only when it flattens the ``[T, B]`` advantages as the
rest of the batch is flattened (``jaxpg.rollout.flatten_samples``, env-major).

The time-major flatten ``x.reshape((-1,) + x.shape[2:])`` gives the same shape, so nothing fails:
the advantages just land on other samples' observations and actions. Notebook 03 did that once and
reported its 8-step-return estimator as far worse than GAE. These tests fail on that bug.

The custom updates are other programs than ``npg.update`` (the same float32 operations, which the
compiler may fuse and order differently on another CPU, vector width or JAX version), so runs are
compared as far as float32 allows (``assert_same_run``):
- Integer state exactly: RNG key and iteration counter after the two iterations.
- The first iteration starts from the same state: its rollout, advantages, gradient and value fit
  are float32 sums of at most a few thousand terms (relative difference <= ~1e-5), and conjugate
  gradient amplifies that by up to the condition number ``1 + lambda_max(F) / cg_damping`` of its
  solve: ``CONFIG``'s damping 1.0 bounds that by ~3 (``lambda_max(F)`` of this policy is 1.5-2.0
  over its two iterations, by power iteration; at the default damping 1e-4 it would be ~2e4), so
  the step's diagnostics differ by <= ~3e-5 and every metric of the first iteration is compared
  with rtol 1e-3 (atol 1e-6 for numbers near zero; the CG residual, itself round-off, is left out).
  The time-major flatten changes the gradient by tens of percent.
- The second iteration steps from parameters that may differ in the last bits, and an episode can
  end a step earlier or later: no float tolerance follows from the computation. The final
  parameters must lie within a tenth of the distance the two iterations moved them; the time-major
  flatten's lie farther than 0.3 of it (measured: 1.9), its updates being other updates.
Measured (``-s``; AMD EPYC, JAX 0.10): the custom updates bit-identical to ``npg.update`` there.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxpg.envs as envs
from jaxpg import returns
from jaxpg import train as train_lib
from jaxpg.algos import core, natural_gradient, npg
from jaxpg.rollout import flatten_samples

ITERATIONS = 2
# T != B, so that a time-major flatten is not a transpose of a square batch.
# cg_damping 1.0: a well-conditioned Fisher solve (module docstring).
CONFIG = npg.Config(
    num_envs=8, horizon=24, policy_hidden=(16,), value_hidden=(16,), value_batch_size=64, cg_damping=1.0
)


def time_major(x):
    """The bug: ``[T, B, ...] -> [T * B, ...]`` with row ``t * B + b``."""
    return x.reshape((-1,) + x.shape[2:])


def handwritten_gae(ts, traj, values, next_values):
    """GAE written as a user would write a custom estimator for ``npg.make_update``."""
    c = ts.config
    return returns.gae(traj.rewards, values, next_values, traj.terminated, traj.truncated, c.gamma, c.gae_lambda)


def composed_update(flatten):
    """Notebook 03's custom update, spelled out phase by phase, with GAE advantages recomputed on the
    ``[T, B]`` trajectory and flattened by ``flatten``."""

    def update(ts):
        old = ts
        ts, traj, key = core.phase_sample(ts)
        value_key, _ = jax.random.split(key)
        batch = core.phase_advantages(ts, traj)  # obs, actions, value targets ...
        values = core.value_predictions(ts, ts.obs_stats.normalize(traj.obs))
        next_values = core.value_predictions(ts, ts.obs_stats.normalize(traj.next_obs))
        adv, _ = handwritten_gae(ts, traj, values, next_values)
        batch = batch.replace(advantages=flatten(returns.normalize(adv, mask=traj.valid)))
        grad = natural_gradient.phase_gradient(ts, batch)
        cg = natural_gradient.phase_natural_gradient(ts, batch, grad)
        step = npg.normalized_step(grad, cg.x, ts.config.kl_delta)
        new_params, kl, fraction = npg.step_within_kl(ts, batch, cg.x, step, npg.kl_bound(ts.config))
        entropy = core.mean_entropy(ts, ts.params, batch)
        ts, value_loss = core.phase_value_fit(ts.replace(params=new_params), batch, value_key)
        metrics = {
            "entropy": entropy,
            "step_length": fraction * step,
            "step_fraction": fraction,
            "cg_residual": cg.residual_norm,
            "grad_norm": jnp.linalg.norm(grad),
            "value_loss": value_loss,
        }
        return core.finish_iteration(
            old, ts, traj, loss=value_loss + kl, kl=kl, metrics=metrics, step_accepted=fraction > 0
        )

    return update


@pytest.fixture(scope="module")
def initial():
    return npg.init(jax.random.PRNGKey(7), envs.make("cartpole"), CONFIG)


def run(update, ts):
    return jax.jit(lambda s: train_lib.scan_updates(update, s, ITERATIONS))(ts)


@pytest.fixture(scope="module")
def reference(initial):
    return run(npg.update, initial)


def param_distance(got, want) -> float:
    """Euclidean distance between the policy parameters of two runs ``(state, metrics)``."""
    pairs = zip(jax.tree.leaves(got[0].params), jax.tree.leaves(want[0].params), strict=True)
    return float(np.sqrt(sum(float(jnp.sum(jnp.square(a - b))) for a, b in pairs)))


def assert_same_run(got, want, initial) -> None:
    """``got`` and ``want`` (``(state, metrics)`` after ``ITERATIONS`` from ``initial``) are the same
    training as far as float32 allows between two programs (module docstring)."""
    (ts, metrics), (ts_ref, metrics_ref) = got, want
    np.testing.assert_array_equal(np.asarray(ts.key), np.asarray(ts_ref.key))
    assert int(ts.iteration) == int(ts_ref.iteration) == ITERATIONS
    assert set(metrics) == set(metrics_ref)
    worst = 0.0
    for k in metrics_ref:
        if k == "cg_residual":
            continue
        a, b = np.asarray(metrics[k][0]), np.asarray(metrics_ref[k][0])
        np.testing.assert_allclose(a, b, rtol=1e-3, atol=1e-6, equal_nan=True, err_msg=k)
        worst = max(worst, float(np.abs(a - b) / max(abs(float(b)), 1e-6)))
    gap, moved = param_distance(got, want), param_distance(want, (initial, None))
    print(f"\nfirst iteration {worst:.1e} relative; final parameters {gap / moved:.1e} of their move")
    assert gap < 0.1 * moved, (gap, moved)


def test_flatten_samples_is_env_major():
    x = jnp.arange(3 * 2 * 4).reshape(3, 2, 4)  # [T=3, B=2, 4]
    flat = flatten_samples(x)
    assert flat.shape == (6, 4)
    for b in range(2):
        for t in range(3):
            np.testing.assert_array_equal(flat[b * 3 + t], x[t, b])
    batch = core.Batch(obs=x, actions=x[..., 0], log_probs=x[..., 1], advantages=x[..., 2], value_targets=x[..., 3],
                       weights=x[..., 0])  # fmt: skip
    flat = core.flatten_batch(batch)  # every field of a Batch the same way
    for field in ("obs", "actions", "log_probs", "advantages", "value_targets", "weights"):
        np.testing.assert_array_equal(getattr(flat, field), flatten_samples(getattr(batch, field)))


def test_make_update_with_gae_reproduces_npg_update(initial, reference):
    update = npg.make_update(handwritten_gae)
    assert update is npg.make_update(handwritten_gae)  # cached: one compiled program per estimator
    assert npg.make_update(core.gae_advantages) is npg.update
    assert_same_run(run(update, initial), reference, initial)


def test_composed_update_reproduces_npg_update_only_with_env_major_flatten(initial, reference):
    """The phase-by-phase update equals ``npg.update`` with ``flatten_samples``; the time-major
    flatten of the notebook's old version (same shapes, no error) gives another update."""
    assert_same_run(run(composed_update(flatten_samples), initial), reference, initial)
    wrong = run(composed_update(time_major), initial)
    moved = param_distance(reference, (initial, None))
    print(f"time-major flatten: final parameters {param_distance(wrong, reference) / moved:.1e} of their move")
    assert param_distance(wrong, reference) > 0.3 * moved
