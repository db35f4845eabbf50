"""NPG and TRPO: the step obeys its trust region, NPG's step as an optax transformation
(``npg.scale_by_natural_gradient``) matches an explicit solve and gives ``npg.update`` the same bits
as the CG-then-step code it replaced, updates are guarded, value targets are standardised on
request. Their learning tests (NPG's ``pendulum_cpu`` preset and TRPO's defaults on
``inverted_pendulum``, two seeds each) are in ``tests/test_learning.py``.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest
from jax.flatten_util import ravel_pytree

import jaxpg.envs as envs
from jaxpg import linalg, profiling
from jaxpg import train as train_lib
from jaxpg import value as value_lib
from jaxpg.algos import core, natural_gradient, npg, trpo

SMALL = dict(num_envs=8, horizon=32, eval_envs=2, eval_horizon=32, value_batch_size=64, cg_damping=1e-2)


@pytest.fixture(scope="module")
def pendulum():
    return envs.make("inverted_pendulum")


@pytest.fixture(scope="module")
def small_state(pendulum):
    return npg.init(jax.random.PRNGKey(3), pendulum, npg.Config(**SMALL))


@pytest.fixture(scope="module")
def batch_and_direction(small_state):
    """Phases of one NPG iteration on a small batch: ``(ts, batch, grad, cg_result)``."""

    @jax.jit
    def phases(ts):
        ts, traj, _ = core.phase_sample(ts)
        batch = core.phase_advantages(ts, traj)
        grad = natural_gradient.phase_gradient(ts, batch)
        return ts, batch, grad, natural_gradient.phase_natural_gradient(ts, batch, grad)

    return phases(small_state)


def test_normalized_step_meets_kl_to_first_order(batch_and_direction):
    """With step ``s = sqrt(delta / g'x)``, the quadratic KL model ``0.5 s^2 x'Fx`` equals
    ``delta / 2``, and for a small delta the true mean KL matches it to within 5 %."""
    ts, batch, grad, cg = batch_and_direction
    delta = 1e-4
    step = npg.normalized_step(grad, cg.x, delta)
    flat, unravel = ravel_pytree(ts.params)
    new_params = unravel(flat + step * cg.x)
    kl = float(core.mean_kl(ts, ts.params, new_params, batch))
    np.testing.assert_allclose(kl, delta / 2, rtol=0.05)
    assert float(cg.residual_norm) < 1e-2 * float(jnp.linalg.norm(grad))


def test_npg_direction_improves_surrogate(batch_and_direction):
    ts, batch, grad, cg = batch_and_direction
    assert float(jnp.dot(grad, cg.x)) > 0  # F^-1 is positive definite: an ascent direction
    flat, unravel = ravel_pytree(ts.params)
    step = npg.normalized_step(grad, cg.x, 1e-3)
    before = natural_gradient.surrogate(ts, ts.params, batch)
    after = natural_gradient.surrogate(ts, unravel(flat + step * cg.x), batch)
    assert float(after) > float(before)


def explicit_problem():
    """Parameters as a pytree of 5 numbers, a gradient and an SPD matrix ``A`` standing for
    ``F + damping I``, with ``x = A^-1 g`` solved by NumPy."""
    rng = np.random.default_rng(0)
    m = rng.normal(size=(5, 5))
    a = m @ m.T + 0.5 * np.eye(5)
    params = {"w": jnp.zeros((2, 2)), "b": jnp.zeros((1,))}
    _, unravel = ravel_pytree(params)
    g = rng.normal(size=5)
    grads = unravel(jnp.asarray(g, jnp.float32))
    fvp = lambda v: unravel(jnp.asarray(a, jnp.float32) @ ravel_pytree(v)[0])  # noqa: E731
    return params, grads, fvp, a, g, np.linalg.solve(a, g)


@pytest.mark.parametrize("use_jit", [True, False], ids=["jit", "nojit"])
def test_scale_by_natural_gradient_is_the_normalised_natural_step(use_jit):
    """``s x`` with ``x = A^-1 g`` and ``s = sqrt(delta / g'x)``, so that ``0.5 u'Au = delta / 2``;
    chained with ``optax.scale(-1)`` (a loss gradient) it is the opposite step."""
    params, grads, fvp, a, g, x = explicit_problem()
    delta = 0.02
    transform = npg.scale_by_natural_gradient(delta, cg_iters=10)
    update = lambda g, s, p: transform.update(g, s, p, fisher_vector_product=fvp)  # noqa: E731
    updates, state = (jax.jit(update) if use_jit else update)(grads, transform.init(params), params)
    assert jax.tree.structure(updates) == jax.tree.structure(params)
    flat = np.asarray(ravel_pytree(updates)[0])
    step = np.sqrt(delta / g.dot(x))
    np.testing.assert_allclose(flat, step * x, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(0.5 * flat @ a @ flat, delta / 2, rtol=1e-4)
    np.testing.assert_allclose(float(state.step_size), step, rtol=1e-4)
    np.testing.assert_array_equal(np.asarray(state.step_size * state.direction), flat)
    assert float(state.cg_residual) < 1e-4

    descend = optax.chain(npg.scale_by_natural_gradient(delta, cg_iters=10), optax.scale(-1.0))
    chain_update = lambda g, s, p: descend.update(g, s, p, fisher_vector_product=fvp)  # noqa: E731
    down, _ = (jax.jit(chain_update) if use_jit else chain_update)(grads, descend.init(params), params)
    np.testing.assert_allclose(np.asarray(ravel_pytree(down)[0]), -flat, rtol=1e-6)
    moved = optax.apply_updates(params, down)
    np.testing.assert_allclose(np.asarray(ravel_pytree(moved)[0]), -flat, rtol=1e-6)


def reference_update(ts):
    """NPG's iteration as it was written before ``scale_by_natural_gradient``: conjugate gradient on
    the flat Fisher-vector product, then the normalised step and its KL back-off."""
    config = ts.config
    old = ts
    ts, traj, key = core.phase_sample(ts)
    value_key, _ = jax.random.split(key)
    batch = core.phase_advantages(ts, traj)
    flat_params, unravel = ravel_pytree(ts.params)
    grad = ravel_pytree(jax.grad(natural_gradient.surrogate, argnums=1)(ts, ts.params, batch))[0]
    obs, weights = natural_gradient.fisher_subsample(ts, batch)
    fvp = linalg.make_fisher_vector_product(
        ts.policy, ts.params, obs, weights=weights, damping=config.cg_damping, mode=config.fvp
    )
    cg = linalg.conjugate_gradient(lambda v: ravel_pytree(fvp(unravel(v)))[0], grad, config.cg_iters)
    step = jnp.sqrt(config.kl_delta / jnp.maximum(jnp.dot(grad, cg.x), 1e-20))
    new_params, kl, fraction = npg.step_within_kl(ts, batch, cg.x, step, npg.kl_bound(config))
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


def test_npg_update_through_the_transform_keeps_its_bits(pendulum):
    """Three iterations of ``npg.update`` (which steps through ``scale_by_natural_gradient``) and of
    the explicit reference give the same bits: parameters, value parameters and every metric. A
    large ``kl_delta`` makes the back-off halve some steps; the Fisher products use a subsample."""
    config = npg.Config(**{**SMALL, "kl_delta": 0.5, "fisher_samples": 100, "eval_envs": 0})
    initial = npg.init(jax.random.PRNGKey(0), pendulum, config)
    run = lambda update: jax.jit(lambda s: train_lib.scan_updates(update, s, 3))(initial)  # noqa: E731
    (ts, metrics), (ts_ref, metrics_ref) = run(npg.update), run(reference_update)
    assert np.any(np.asarray(metrics["step_fraction"]) < 1)
    got, want = jax.tree.leaves((ts.params, ts.value_params)), jax.tree.leaves((ts_ref.params, ts_ref.value_params))
    for a, b in zip(got, want, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert set(metrics) == set(metrics_ref)
    for k in metrics:
        np.testing.assert_array_equal(np.asarray(metrics[k]), np.asarray(metrics_ref[k]), err_msg=k)
    # Unrolling the learner's loops (GAE, the value fit, CG) changes how they compile, not the
    # arithmetic: the first iteration agrees to float32 rounding. Rounding then moves CG's later
    # iterates (its residual is ~1e-3 here), so later iterations agree only to that level.
    unrolled = npg.init(jax.random.PRNGKey(0), pendulum, dataclasses.replace(config, loop_unroll=4))
    ts_unrolled, metrics_unrolled = jax.jit(lambda s: train_lib.scan_updates(npg.update, s, 3))(unrolled)
    for k in metrics:
        got, want = np.asarray(metrics_unrolled[k]), np.asarray(metrics[k])
        np.testing.assert_allclose(got[0], want[0], rtol=1e-5, atol=1e-6, err_msg=k)
        np.testing.assert_allclose(got, want, rtol=2e-2, atol=1e-3, err_msg=k)
    with pytest.raises(ValueError, match="loop_unroll"):
        dataclasses.replace(config, loop_unroll=0).validate(pendulum)


def test_trpo_line_search_respects_max_kl(batch_and_direction):
    ts, batch, grad, cg = batch_and_direction
    ts = ts.replace(config=trpo.Config(**SMALL, max_kl=0.01))
    new_params, info = jax.jit(trpo.line_search)(ts, batch, grad, cg.x)
    kl = float(core.mean_kl(ts, ts.params, new_params, batch))
    # On this batch the search must take a step: a search that always rejects (KL 0) fails here.
    assert float(info["line_search_accepted"]) == 1.0 and 0 < kl <= 0.01 + 1e-6
    assert float(info["surrogate_improvement"]) > 0
    np.testing.assert_allclose(kl, float(info["kl"]), rtol=1e-4)
    # With a trust region so large that every candidate overshoots the quadratic model, it rejects
    # and says so: the policy is unchanged.
    huge = ts.replace(config=trpo.Config(**SMALL, max_kl=1e6))
    same, info = jax.jit(trpo.line_search)(huge, batch, grad, cg.x)
    assert float(info["line_search_accepted"]) == 0.0 and float(info["step_length"]) == 0.0
    for a, b in zip(jax.tree.leaves(same), jax.tree.leaves(ts.params), strict=True):
        np.testing.assert_array_equal(a, b)


def test_nonfinite_update_is_rejected(small_state):
    """An update that produces NaN parameters leaves the learned state untouched and is counted."""
    old = small_state
    poisoned = old.replace(params=jax.tree.map(lambda x: x * jnp.nan, old.params))
    kept, rejected = core.accept_if_finite(old, poisoned, jnp.array(0.0))
    assert float(rejected) == 1.0 and int(kept.failures) == 1
    for a, b in zip(jax.tree.leaves(kept.params), jax.tree.leaves(old.params), strict=True):
        np.testing.assert_array_equal(a, b)
    kept, rejected = core.accept_if_finite(old, old, jnp.array(jnp.inf))
    assert float(rejected) == 1.0


def test_diverging_run_stops_with_clear_error(small_state):
    """A run whose updates keep failing raises ``TrainingDiverged`` instead of training on."""

    def failing_update(ts):
        return ts.replace(failures=ts.failures + 1), {"return_stochastic": jnp.nan}

    with pytest.raises(train_lib.TrainingDiverged, match="non-finite"):
        train_lib.train(failing_update, small_state, 10, block_size=5, max_consecutive_failures=3)


def test_profile_phases_compute_the_fused_update(small_state):
    """The profiled iteration is NPG's iteration: its separately jitted phases, timed in the order
    they run, leave the state that the fused ``npg.update`` leaves when that takes the full step
    (no backtracking) and keeps it (the profiled phases neither back off nor reject). What is
    compared: the PRNG key and iteration count exactly (integer arithmetic), the env state after
    sampling, and the policy's and value function's changes.

    Tolerances: the phases are separate XLA programs and the update one fused program, so float32
    sums may be reassociated (the physics of the rollout, the gradient's batch mean, CG's dot
    products, which CG amplifies, and the value fit's Adam steps); such differences stay near 1e-6
    relative, while a skipped, doubled or misdirected step changes the parameter change by O(1)
    of its norm. So: env state to 1e-5 relative (atol 1e-6 for values near 0), each parameter
    change to 1e-3 of its norm."""
    ts, timings = profiling.profile_phases("npg", small_state)
    assert list(timings) == ["sampling", "advantages", "gradient", "cg", "value_fit"]
    assert all(isinstance(t, float) and np.isfinite(t) for t in timings.values()), timings
    fused, metrics = jax.jit(npg.update)(small_state)
    assert float(metrics["step_fraction"]) == 1.0 and float(metrics["update_rejected"]) == 0.0, metrics
    np.testing.assert_array_equal(ts.key, fused.key)
    assert int(ts.iteration) == int(fused.iteration) == int(small_state.iteration) + 1
    jax.tree.map(lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6), ts.env_state, fused.env_state)
    assert not ts.config.normalize_observations  # the profiled phases leave obs statistics alone
    for name in ("params", "value_params"):
        before = ravel_pytree(getattr(small_state, name))[0]
        profiled = ravel_pytree(getattr(ts, name))[0] - before
        updated = ravel_pytree(getattr(fused, name))[0] - before
        assert float(jnp.linalg.norm(updated)) > 0, name
        np.testing.assert_allclose(profiled, updated, rtol=0, atol=1e-3 * float(jnp.linalg.norm(updated)))


def test_same_seed_same_numbers_and_seed_vmap_matches(pendulum):
    """Training is bit-for-bit deterministic for a seed, and two seeds trained in one vmapped
    program give the numbers of training each alone.

    Batched matrix products sum in another order than unbatched ones, and conjugate gradient in
    float32 amplifies such last-bit differences (its residual is round-off, compared loosely);
    after the first update an episode can end a step earlier or later. So: every metric of the
    first iteration agrees to 1e-3, and the update's own diagnostics of the second to 2e-2; a
    seed mix-up or a shared key would differ by far more.
    """
    config = npg.Config(**SMALL)
    alone = []
    for seed in (1, 2):
        ts = npg.init(jax.random.PRNGKey(seed), pendulum, config)
        _, metrics = train_lib.compiled_block(npg.update, 2, False)(ts)
        alone.append(metrics)
    ts = npg.init(jax.random.PRNGKey(1), pendulum, config)
    _, again = train_lib.compiled_block(npg.update, 2, False)(ts)
    for key in alone[0]:
        np.testing.assert_array_equal(alone[0][key], again[key])
    stacked = train_lib.init_seeds(npg.init, (1, 2), pendulum, config)
    _, together = train_lib.compiled_block(npg.update, 2, True)(stacked)
    mismatches = []
    for i in range(2):
        for key in alone[i]:
            if key == "cg_residual":
                tol = 1e-2 * float(alone[i]["grad_norm"][0])
                assert float(together[key][0, i]) < tol and float(alone[i][key][0]) < tol
                continue
            if not np.allclose(together[key][0, i], alone[i][key][0], rtol=1e-3, atol=1e-5, equal_nan=True):
                mismatches.append((i, 0, key, float(together[key][0, i]), float(alone[i][key][0])))
        for key in ("kl", "value_loss", "grad_norm", "step_length"):
            if not np.allclose(together[key][1, i], alone[i][key][1], rtol=2e-2):
                mismatches.append((i, 1, key, float(together[key][1, i]), float(alone[i][key][1])))
    assert not mismatches, mismatches


def test_normalized_value_targets(small_state):
    """With ``normalize_value_targets`` the target statistics absorb each batch, the network is
    fitted to standardised targets, the output layer is rescaled so that its predictions in
    return units survive a move of the statistics, and a rolled-back update restores the
    statistics too."""
    config = npg.Config(**SMALL, normalize_value_targets=True)
    ts = small_state.replace(config=config)
    ts, traj, key = jax.jit(core.phase_sample)(ts)
    batch = jax.jit(core.phase_advantages)(ts, traj)
    # Targets on the scale of a long task's returns (hundreds), far from standardised.
    batch = batch.replace(value_targets=300.0 + 50.0 * batch.value_targets)
    before = core.value_predictions(ts, batch.obs)
    np.testing.assert_allclose(before, ts.value_fn.apply(ts.value_params, batch.obs), rtol=1e-6)  # identity at start

    def absorb(state, b):
        """``state`` with its target statistics moved by batch ``b`` and its outputs preserved."""
        stats = state.value_stats.update(b.value_targets[:, None], b.weights)
        old = state.value_stats
        params = value_lib.preserve_outputs(state.value_params, old.mean[0], old.std[0], stats.mean[0], stats.std[0])
        return state.replace(value_stats=stats, value_params=params)

    preserved = absorb(ts, batch)
    moved = preserved.value_stats
    np.testing.assert_allclose(core.value_predictions(preserved, batch.obs), before, rtol=1e-4, atol=1e-3)

    fitted, loss = jax.jit(core.phase_value_fit)(ts, batch, key)
    np.testing.assert_allclose(fitted.value_stats.mean, moved.mean, rtol=1e-6)
    np.testing.assert_allclose(fitted.value_stats.var, moved.var, rtol=1e-6)
    targets = batch.value_targets
    raw_outputs = ts.value_fn.apply(fitted.value_params, batch.obs)
    assert abs(float(jnp.mean(raw_outputs))) < 1.0  # the network itself predicts standardised targets
    # A second batch on a higher level: the fit starts from the first fit's predictions, kept.
    again = batch.replace(value_targets=batch.value_targets + 200.0)
    kept = core.value_predictions(fitted, again.obs)
    np.testing.assert_allclose(core.value_predictions(absorb(fitted, again), again.obs), kept, rtol=1e-4, atol=1e-2)
    assert np.isfinite(float(loss))
    err_before = float(jnp.mean(jnp.square(before - targets)))
    err_after = float(jnp.mean(jnp.square(core.value_predictions(fitted, batch.obs) - targets)))
    assert err_after < err_before

    kept, rejected = core.accept_if_finite(ts, fitted, jnp.array(jnp.nan))
    assert float(rejected) == 1.0
    np.testing.assert_array_equal(kept.value_stats.mean, ts.value_stats.mean)
    np.testing.assert_array_equal(kept.value_stats.count, ts.value_stats.count)


def test_value_minibatches_split_each_epoch(pendulum):
    """``value_minibatches`` sets the minibatch size from the batch; out of range is refused."""
    config = npg.Config(**{**SMALL, "value_minibatches": 4})
    assert config.value_minibatch_size == 8 * 32 // 4
    config.validate(pendulum)
    assert npg.Config(**SMALL).value_minibatch_size == SMALL["value_batch_size"]
    for bad in (-1, 8 * 32 + 1):
        with pytest.raises(ValueError, match="value_minibatches"):
            npg.Config(**{**SMALL, "value_minibatches": bad}).validate(pendulum)


def test_value_epoch_samples_caps_the_minibatches(pendulum):
    """``value_epoch_samples`` below the batch sets the minibatch size from the cap; above it, it
    changes nothing; fewer samples than minibatches, or a negative cap, is refused."""
    capped = npg.Config(**{**SMALL, "value_minibatches": 4, "value_epoch_samples": 64})
    assert (capped.value_samples_per_epoch, capped.value_minibatch_size) == (64, 16)
    capped.validate(pendulum)
    loose = npg.Config(**{**SMALL, "value_minibatches": 4, "value_epoch_samples": 10_000})
    assert loose.value_minibatch_size == 8 * 32 // 4
    for bad in (-1, 3):
        with pytest.raises(ValueError, match="value_epoch_samples"):
            npg.Config(**{**SMALL, "value_minibatches": 4, "value_epoch_samples": bad}).validate(pendulum)


def test_fisher_samples_draws_a_subset_for_the_solve(pendulum):
    """``fisher_samples`` below the batch builds the Fisher-vector products from that many rows
    of the batch (a fresh draw each iteration); at or above it, from all of them, so that the
    update is unchanged; a negative count is refused."""
    ts = npg.init(jax.random.PRNGKey(0), pendulum, npg.Config(**SMALL))
    ts, traj, _ = core.phase_sample(ts)
    batch = core.phase_advantages(ts, traj)
    obs, weights = natural_gradient.fisher_subsample(ts, batch)
    assert obs is batch.obs and weights is batch.weights
    sub = ts.replace(config=npg.Config(**{**SMALL, "fisher_samples": 32}))
    obs, weights = natural_gradient.fisher_subsample(sub, batch)
    assert obs.shape == (32, batch.obs.shape[1]) and weights.shape == (32,)
    rows = [int(np.flatnonzero(np.all(np.asarray(batch.obs) == row, axis=1))[0]) for row in np.asarray(obs)]
    np.testing.assert_array_equal(np.asarray(weights), np.asarray(batch.weights)[rows])
    again, _ = natural_gradient.fisher_subsample(sub.replace(key=jax.random.PRNGKey(1)), batch)
    assert not np.array_equal(np.asarray(again), np.asarray(obs))
    full = ts.replace(config=npg.Config(**{**SMALL, "fisher_samples": 8 * 32}))
    assert natural_gradient.fisher_subsample(full, batch)[0] is batch.obs
    with pytest.raises(ValueError, match="fisher_samples"):
        npg.Config(**{**SMALL, "fisher_samples": -1}).validate(pendulum)
