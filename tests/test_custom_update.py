"""A custom NPG update assembled from the phase functions (notebook 03, section 1) is NPG itself
when its advantage estimator is GAE, and only when it flattens the ``[T, B]`` advantages as the
rest of the batch is flattened (``jaxpg.rollout.flatten_samples``, env-major).

The time-major flatten ``x.reshape((-1,) + x.shape[2:])`` gives the same shape, so nothing fails:
the advantages just land on other samples' observations and actions. Notebook 03 did that once and
reported its 8-step-return estimator as far worse than GAE. These tests fail on that bug.
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
CONFIG = npg.Config(num_envs=8, horizon=24, policy_hidden=(16,), value_hidden=(16,), value_batch_size=64)


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


def assert_same_run(got, want):
    (ts, metrics), (ts_ref, metrics_ref) = got, want
    for name, tree, tree_ref in [
        ("params", ts.params, ts_ref.params),
        ("value_params", ts.value_params, ts_ref.value_params),
    ]:
        for a, b in zip(jax.tree.leaves(tree), jax.tree.leaves(tree_ref), strict=True):
            np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-5, atol=1e-6, err_msg=name)
    assert set(metrics) == set(metrics_ref)
    for k in metrics_ref:
        np.testing.assert_allclose(
            np.asarray(metrics[k]), np.asarray(metrics_ref[k]), rtol=1e-5, atol=1e-6, equal_nan=True, err_msg=k
        )


def param_distance(got, want) -> float:
    pairs = zip(jax.tree.leaves(got[0].params), jax.tree.leaves(want[0].params), strict=True)
    return max(float(jnp.max(jnp.abs(a - b))) for a, b in pairs)


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
    assert_same_run(run(update, initial), reference)


def test_composed_update_reproduces_npg_update_only_with_env_major_flatten(initial, reference):
    """The phase-by-phase update equals ``npg.update`` with ``flatten_samples``; the time-major
    flatten of the notebook's old version (same shapes, no error) gives another update."""
    assert_same_run(run(composed_update(flatten_samples), initial), reference)
    wrong = run(composed_update(time_major), initial)
    assert param_distance(wrong, reference) > 1e-3
