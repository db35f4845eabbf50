"""NPG and TRPO: the step obeys its trust region, NPG's step as an optax transformation
(``npg.scale_by_natural_gradient``) matches an explicit solve, one ``npg.update`` matches a float64
NumPy reference (GAE, policy gradient, dense Fisher, normalised step, KL back-off), updates are
guarded, value targets are standardised on request. Their learning tests (NPG's ``pendulum_cpu``
preset and TRPO's defaults on ``inverted_pendulum``, two seeds each) are in ``tests/test_learning.py``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import numpy_reference as ref
import optax
import pytest
from jax.flatten_util import ravel_pytree

import jaxpg.envs as envs
from jaxpg import train as train_lib
from jaxpg import value as value_lib
from jaxpg.algos import core, natural_gradient, npg, trpo
from jaxpg.run.host import profiling

SMALL = dict(num_envs=8, horizon=32, eval_envs=2, eval_horizon=32, value_batch_size=64, cg_damping=1e-2)


@pytest.fixture(scope="module")
def pendulum():
    return envs.make("inverted_pendulum")


@pytest.fixture(scope="module")
def small_state(pendulum):
    return npg.init(jax.random.PRNGKey(3), pendulum, npg.Config(**SMALL))


@pytest.fixture(scope="module")
def sampled_phases(small_state):
    """Phases of one NPG iteration on a small batch: ``(ts, traj, batch, grad, cg_result)``."""

    @jax.jit
    def phases(ts):
        ts, traj, _ = core.phase_sample(ts)
        batch = core.phase_advantages(ts, traj)
        grad = natural_gradient.phase_gradient(ts, batch)
        return ts, traj, batch, grad, natural_gradient.phase_natural_gradient(ts, batch, grad)

    return phases(small_state)


@pytest.fixture(scope="module")
def batch_and_direction(sampled_phases):
    """``(ts, batch, grad, cg_result)`` of ``sampled_phases``."""
    ts, _, batch, grad, cg = sampled_phases
    return ts, batch, grad, cg


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


# kl_delta of the NumPy check below: above max_update_kl (1), which then bounds the step's KL, and
# large enough that the full normalised step overshoots that bound, so that the back-off halves it.
BACKOFF_KL_DELTA = 4.0


def test_npg_update_matches_numpy_reference(small_state, sampled_phases):
    """One ``npg.update`` against float64 NumPy: the advantages and value targets are GAE over the
    value network's predictions, standardised over the valid samples; the policy gradient is
    ``E_w[A grad log pi]``; the step taken is ``f s x`` where ``x`` solves the dense
    ``(F + damping I) x = g`` to the residual the solver reports, ``s = sqrt(kl_delta / g'x)`` and
    ``f`` is the first of ``1, 1/2, 1/4 ...`` whose mean KL (Gaussian closed form) is within
    ``min(kl_delta, max_update_kl)``; the reported KL and entropy are NumPy's."""
    config = small_state.config
    new, metrics = jax.jit(npg.update_with_kl_delta)(small_state, BACKOFF_KL_DELTA)
    ts, traj, batch, grad, _ = sampled_phases  # the same key, so the batch the update sampled
    assert float(metrics["update_rejected"]) == 0.0

    # GAE, [T, B] time-major, then flattened env-major as the batch is.
    value_params = ref.to_numpy(ts.value_params)
    obs, next_obs = np.asarray(traj.obs, np.float64), np.asarray(traj.next_obs, np.float64)
    values = ref.mlp_forward(value_params, obs.reshape(-1, obs.shape[-1]), config.value_activation)[0]
    next_values = ref.mlp_forward(value_params, next_obs.reshape(-1, obs.shape[-1]), config.value_activation)[0]
    values, next_values = values.reshape(obs.shape[:2]), next_values.reshape(obs.shape[:2])
    rewards, terminated, truncated = (np.asarray(a) for a in (traj.rewards, traj.terminated, traj.truncated))
    assert terminated.any()  # episodes end inside the batch
    advantages = ref.gae(rewards, values, next_values, terminated, truncated, config.gamma, config.gae_lambda)
    valid = np.asarray(traj.valid, bool)
    targets = advantages + values
    advantages = np.where(valid, (advantages - advantages[valid].mean()) / advantages[valid].std(), 0.0)
    # float32 recursions over 32 steps of values and returns of size ~10: errors ~1e-5.
    np.testing.assert_allclose(np.asarray(batch.advantages), advantages.T.reshape(-1), rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(np.asarray(batch.value_targets), targets.T.reshape(-1), rtol=1e-4, atol=1e-4)

    params = ref.to_numpy(ts.params)
    numpy_batch = {name: np.asarray(getattr(batch, name), np.float64) for name in ref.BATCH_FIELDS}
    act = config.policy_activation
    dist = ref.policy_forward("gaussian", params, numpy_batch["obs"], act)
    var = np.exp(2.0 * dist["log_std"])
    residual = numpy_batch["actions"] - dist["mean"]
    c = numpy_batch["weights"] / numpy_batch["weights"].sum()
    ca = (c * numpy_batch["advantages"])[:, None]
    upstream = {"mean": ca * residual / var, "log_std": ca * (residual**2 / var - 1.0)}
    want_grad = ref.flat(ref.policy_backward("gaussian", params, dist, upstream, act))
    grad_norm = np.linalg.norm(want_grad)
    # Sums over 256 samples through two 64-unit layers in float32: ~1e-5 of the gradient's norm.
    np.testing.assert_allclose(np.asarray(grad), want_grad, rtol=0, atol=1e-4 * grad_norm)
    np.testing.assert_allclose(float(metrics["grad_norm"]), grad_norm, rtol=1e-4)

    fraction, step_length = float(metrics["step_fraction"]), float(metrics["step_length"])
    assert 0 < fraction < 1  # the back-off halved the step at least once
    step_size = step_length / fraction
    taken = ref.flat(ref.to_numpy(new.params)) - ref.flat(params)
    direction = taken / step_length
    # The normalised step length, written out: s = sqrt(kl_delta / g'x).
    np.testing.assert_allclose(step_size, np.sqrt(BACKOFF_KL_DELTA / (want_grad @ direction)), rtol=1e-3)
    fisher = ref.gaussian_fisher(params, numpy_batch["obs"], numpy_batch["weights"], act)
    solve_residual = np.linalg.norm(fisher @ direction + config.cg_damping * direction - want_grad)
    # Ten float32 CG iterations: the residual is what the solver reports, to float32 drift of its
    # recursion (~1e-3 of ||g||), and small.
    assert abs(solve_residual - float(metrics["cg_residual"])) < 2e-3 * grad_norm
    assert solve_residual < 2e-2 * grad_norm

    bound = min(BACKOFF_KL_DELTA, config.max_update_kl) if config.max_update_kl > 0 else BACKOFF_KL_DELTA
    kls = []
    for k in range(npg.BACKTRACKS):
        candidate = ref.unflat(ref.flat(params) + 0.5**k * step_size * direction, params)
        kls.append(c @ ref.kl("gaussian", dist, ref.policy_forward("gaussian", candidate, numpy_batch["obs"], act)))
    first = int(np.argmax(np.array(kls) <= bound))
    assert kls[first] <= bound and all(kl > 1.01 * bound for kl in kls[:first])  # clear decisions
    assert fraction == 0.5**first
    # KL of ~0.1 from float32 distributions: cancellations leave ~1e-6 absolute.
    np.testing.assert_allclose(float(metrics["kl"]), kls[first], rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(float(metrics["entropy"]), np.mean(ref.entropy("gaussian", dist)), rtol=1e-6)


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
    """The profiled iteration is NPG's iteration, written once (``npg.iteration``): its separately
    jitted phases, timed in the order they run, leave the state and metrics that the fused
    ``npg.update`` leaves, KL back-off and guard included. What is compared: the PRNG key and
    iteration count exactly (integer arithmetic), the env state after sampling, and the policy's
    and value function's changes.

    Tolerances: the phases are separate XLA programs and the update one fused program, so float32
    sums may be reassociated (the physics of the rollout, the gradient's batch mean, CG's dot
    products, which CG amplifies, and the value fit's Adam steps); such differences stay near 1e-6
    relative, while a skipped, doubled or misdirected step changes the parameter change by O(1)
    of its norm. So: env state to 1e-5 relative (atol 1e-6 for values near 0), each parameter
    change to 1e-3 of its norm."""
    ts, timings = profiling.profile_phases("npg", small_state)
    assert tuple(timings) == npg.PHASES
    assert all(isinstance(t, float) and np.isfinite(t) for t in timings.values()), timings
    fused, metrics = jax.jit(npg.update)(small_state)
    assert float(metrics["step_fraction"]) == 1.0 and float(metrics["update_rejected"]) == 0.0, metrics
    np.testing.assert_array_equal(ts.key, fused.key)
    assert int(ts.iteration) == int(fused.iteration) == int(small_state.iteration) + 1
    jax.tree.map(lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6), ts.env_state, fused.env_state)
    for name in ("params", "value_params"):
        before = ravel_pytree(getattr(small_state, name))[0]
        profiled = ravel_pytree(getattr(ts, name))[0] - before
        updated = ravel_pytree(getattr(fused, name))[0] - before
        assert float(jnp.linalg.norm(updated)) > 0, name
        np.testing.assert_allclose(profiled, updated, rtol=0, atol=1e-3 * float(jnp.linalg.norm(updated)))


def test_npg_update_is_its_iteration_run_inline(small_state):
    """``update`` is ``iteration`` with every phase inline: one program, the same bits."""
    recorded = []

    def record(name, fn, *args):
        recorded.append(name)
        return fn(*args)

    via_phases, phase_metrics = jax.jit(lambda ts: npg.iteration(ts, record))(small_state)
    fused, metrics = jax.jit(npg.update)(small_state)
    assert tuple(recorded) == npg.PHASES
    jax.tree.map(np.testing.assert_array_equal, (via_phases.params, phase_metrics), (fused.params, metrics))


# Metrics of an iteration that discriminate between seeds 1 and 2 (they differ by 10-90 % between
# the two seeds) and that do not pass through the conjugate-gradient solve.
SEED_DISCRIMINATING = ("value_loss", "grad_norm", "return_stochastic", "episode_length")


def test_same_seed_same_numbers_and_seed_vmap_matches(pendulum):
    """Training is bit-for-bit deterministic for a seed, and two seeds trained in one vmapped
    program give the numbers of training each alone.

    The vmapped program is another program: its batched matrix products may sum in another float32
    order than the unbatched ones (CPU models and vector widths decide), so its numbers may differ
    from the unbatched ones in the last bits, and what can be compared depends on what amplifies
    those bits:
    - The first iteration starts from the same parameters and keys. Its rollout, advantages and
      value fit are float32 sums of at most a few thousand terms (relative difference <= ~1e-5),
      and its policy step solves ``(F + damping I) x = g`` by conjugate gradient, which amplifies a
      relative perturbation by up to the condition number of ``F + damping I``. With this test's
      ``cg_damping=1.0`` that number is below ~1e2 (the Fisher matrix of this small Gaussian
      policy has eigenvalues of order 1-10), so the step's diagnostics differ by <= ~1e-4: every
      metric is compared with rtol 1e-3 (the CG residual, itself round-off, only against its
      bound). At the suite's ``cg_damping=1e-2`` the condition number is ~1e4 and the measured KL
      of vmapped and unvmapped programs was seen to differ by 2.7e-3 on one CPU.
    - From the second iteration on the two programs step from parameters that may differ in the
      last bits, and an episode can end a step earlier or later: no float tolerance follows from
      the computation there. What must hold exactly are the integer states (RNG keys, iteration
      counters), and what a seed mix-up or a shared key would break is that each seed's metrics
      lie far closer to its own solo run than to the other seed's (``SEED_DISCRIMINATING``).
    """
    config = npg.Config(**{**SMALL, "cg_damping": 1.0})
    alone = []
    for seed in (1, 2):
        ts = npg.init(jax.random.PRNGKey(seed), pendulum, config)
        alone.append(train_lib.compiled_block(npg.update, 2, False)(ts))
    ts = npg.init(jax.random.PRNGKey(1), pendulum, config)
    again_state, again = train_lib.compiled_block(npg.update, 2, False)(ts)
    for key in alone[0][1]:
        np.testing.assert_array_equal(alone[0][1][key], again[key], err_msg=key)
    for a, b in zip(jax.tree.leaves(alone[0][0]), jax.tree.leaves(again_state), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    stacked = train_lib.init_seeds(npg.init, (1, 2), pendulum, config)
    together_state, together = train_lib.compiled_block(npg.update, 2, True)(stacked)
    mismatches = []
    for i in range(2):
        state_alone, metrics_alone = alone[i]
        np.testing.assert_array_equal(np.asarray(together_state.key[i]), np.asarray(state_alone.key))
        np.testing.assert_array_equal(np.asarray(together_state.iteration[i]), np.asarray(state_alone.iteration))
        for key in metrics_alone:
            if key == "cg_residual":
                tol = 1e-2 * float(metrics_alone["grad_norm"][0])
                assert float(together[key][0, i]) < tol and float(metrics_alone[key][0]) < tol
                continue
            if not np.allclose(together[key][0, i], metrics_alone[key][0], rtol=1e-3, atol=1e-5, equal_nan=True):
                mismatches.append((i, 0, key, float(together[key][0, i]), float(metrics_alone[key][0])))
        other = alone[1 - i][1]
        for key in SEED_DISCRIMINATING:
            for it in range(2):
                own_gap = abs(float(together[key][it, i]) - float(metrics_alone[key][it]))
                seed_gap = abs(float(other[key][it]) - float(metrics_alone[key][it]))
                assert seed_gap > 0.05 * abs(float(metrics_alone[key][it])), (key, it)  # the seeds do differ
                if not own_gap < 0.1 * seed_gap:
                    mismatches.append((i, it, key, float(together[key][it, i]), float(metrics_alone[key][it])))
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


def test_trpo_profiles_its_own_phases(pendulum):
    ts = trpo.init(jax.random.PRNGKey(3), pendulum, trpo.Config(**SMALL))
    profiled, timings = profiling.profile_phases("trpo", ts)
    assert tuple(timings) == trpo.PHASES
    assert int(profiled.iteration) == int(ts.iteration) + 1
