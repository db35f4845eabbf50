"""Conjugate gradient against ``numpy.linalg.solve``; Fisher-vector products against explicit
Fisher matrices built two independent ways (Hessian of the KL, and ``J^T M J``)."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.flatten_util import ravel_pytree
from scipy import special

from jaxpg import linalg as L
from jaxpg.policies import CategoricalPolicy, GaussianPolicy, StateStdGaussianPolicy


def maybe_jit(fn, use_jit, **kwargs):
    return jax.jit(fn, **kwargs) if use_jit else fn


def random_spd(n, seed, cond=20.0):
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return (q * np.geomspace(1.0, cond, n)) @ q.T, rng.normal(size=n)


# -- Conjugate gradient --------------------------------------------------------------------------


@pytest.mark.parametrize("use_jit", [False, True])
def test_cg_flat_matches_solve(use_jit):
    a, b = random_spd(10, 0)
    a32 = jnp.asarray(a, jnp.float32)
    cg = maybe_jit(lambda b: L.conjugate_gradient(lambda v: a32 @ v, b, iters=30, residual_tol=1e-6), use_jit)
    res = cg(jnp.asarray(b, jnp.float32))
    np.testing.assert_allclose(res.x, np.linalg.solve(a, b), rtol=1e-3, atol=1e-4)
    assert res.residual_norm.shape == () and float(res.residual_norm) <= 1e-4
    np.testing.assert_allclose(res.residual_norm, np.linalg.norm(b - a @ np.asarray(res.x, np.float64)), atol=1e-4)
    assert 10 <= int(res.iterations) < 30  # converged, then frozen
    # A traced iteration count (notebook 05 vmaps CG over iteration counts).
    counts = jnp.asarray([5, 30])
    by_count = jax.vmap(lambda k: L.conjugate_gradient(lambda v: a32 @ v, jnp.asarray(b, jnp.float32), k).x)
    np.testing.assert_allclose(by_count(counts)[1], res.x, rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("use_jit", [False, True])
def test_cg_pytree_matches_solve(use_jit):
    a, b = random_spd(7, 1)
    a32 = jnp.asarray(a, jnp.float32)
    tree = {"u": jnp.asarray(b[:3].reshape(3, 1), jnp.float32), "v": [jnp.asarray(b[3:], jnp.float32)]}
    _, unravel = ravel_pytree(tree)

    def matvec(t):
        flat, _ = ravel_pytree(t)
        return unravel(a32 @ flat)

    res = maybe_jit(lambda t: L.conjugate_gradient(matvec, t, iters=7), use_jit)(tree)
    assert jax.tree.structure(res.x) == jax.tree.structure(tree)
    np.testing.assert_allclose(ravel_pytree(res.x)[0], np.linalg.solve(a, b), rtol=1e-3, atol=1e-4)


def test_cg_early_stop_freezes_iterate():
    a, b = random_spd(12, 2, cond=100.0)
    a32, b32 = jnp.asarray(a, jnp.float32), jnp.asarray(b, jnp.float32)
    res = jax.jit(lambda b: L.conjugate_gradient(lambda v: a32 @ v, b, iters=12, residual_tol=0.1))(b32)
    k = int(res.iterations)
    assert 0 < k < 12 and float(res.residual_norm) <= 0.1
    fewer = L.conjugate_gradient(lambda v: a32 @ v, b32, iters=k)
    np.testing.assert_allclose(res.x, fewer.x, rtol=1e-6)
    assert int(fewer.iterations) == k
    assert float(L.conjugate_gradient(lambda v: a32 @ v, b32, iters=k - 1).residual_norm) > 0.1
    # A zero right-hand side takes no steps; vmap over right-hand sides works.
    zero = L.conjugate_gradient(lambda v: a32 @ v, jnp.zeros(12), iters=5)
    assert int(zero.iterations) == 0 and not np.any(zero.x)
    batched = jax.vmap(lambda b: L.conjugate_gradient(lambda v: a32 @ v, b, iters=40).x)(jnp.stack([b32, 2 * b32]))
    np.testing.assert_allclose(batched[1], 2 * batched[0], rtol=1e-3, atol=1e-4)


# -- Fisher-vector products ----------------------------------------------------------------------

OBS, N = 3, 6
POLICIES = {
    "gaussian": GaussianPolicy(action_size=2, hidden=(4,)),
    "state_std": StateStdGaussianPolicy(action_size=2, hidden=(3,)),
    "categorical": CategoricalPolicy(num_actions=3, hidden=(4,)),
}


def setup(name):
    policy = POLICIES[name]
    params = policy.init(jax.random.key(0), OBS)
    obs = jax.random.normal(jax.random.key(1), (N, OBS))
    flat, unravel = ravel_pytree(params)
    weights = np.random.default_rng(0).uniform(size=N).astype(np.float32)
    weights[2] = 0.0
    return policy, params, obs, flat, unravel, weights


def explicit_fisher_hessian(policy, params, obs, weights):
    """``F`` as the Hessian of the weighted mean KL(pi_params || pi_theta) at theta = params."""
    flat, unravel = ravel_pytree(params)
    old = jax.lax.stop_gradient(policy.dist(params, obs))
    w = weights / weights.sum()
    hessian = jax.jit(jax.hessian(lambda f: jnp.sum(w * policy.dist_kl(old, policy.dist(unravel(f), obs)))))
    return np.asarray(hessian(flat), np.float64)


@functools.cache
def fisher_blocks(name):
    """Per-sample ``J_i^T M_i J_i`` ``[N, P, P]``, with the analytic metric written out in NumPy."""
    policy, params, obs, flat, unravel, _ = setup(name)
    dist = policy.dist(params, obs)

    def per_sample(f):  # [N, D]: each sample's distribution parameters, leaves in sorted-key order
        return jnp.concatenate([x.reshape(N, -1) for x in jax.tree.leaves(policy.dist(unravel(f), obs))], axis=1)

    jac = np.asarray(jax.jit(jax.jacobian(per_sample))(flat), np.float64)  # [N, D, P]
    blocks = []
    for i in range(N):
        if policy.discrete:
            p = special.softmax(np.asarray(dist["logits"][i], np.float64))
            m = np.diag(p) - np.outer(p, p)
        else:  # {"log_std", "mean"}: log-std first
            inv_var = np.exp(-2.0 * np.asarray(dist["log_std"][i], np.float64))
            m = np.diag(np.concatenate([2.0 * np.ones_like(inv_var), inv_var]))
        blocks.append(jac[i].T @ m @ jac[i])
    return np.stack(blocks)


def explicit_fisher_jacobian(name, weights):
    """``F = sum_i w_i J_i^T M_i J_i / sum_i w_i``."""
    return np.einsum("i,ipq->pq", weights, fisher_blocks(name)) / weights.sum()


@pytest.mark.parametrize("name", list(POLICIES))
def test_explicit_fisher_matrices_agree(name):
    policy, params, obs, _, _, weights = setup(name)
    np.testing.assert_allclose(
        explicit_fisher_hessian(policy, params, obs, weights),
        explicit_fisher_jacobian(name, weights),
        rtol=1e-4,
        atol=1e-5,
    )


@pytest.mark.parametrize("name, use_jit", [("gaussian", False)] + [(name, True) for name in POLICIES])
def test_fisher_vector_product_matches_explicit(name, use_jit):
    policy, params, obs, flat, unravel, weights = setup(name)
    f_mean = explicit_fisher_jacobian(name, np.ones(N))
    f_weighted = explicit_fisher_jacobian(name, weights)
    v = np.random.default_rng(1).normal(size=flat.size).astype(np.float32)
    for mode in ("gauss_newton", "kl_hessian"):

        def fvp(p, o, v, w, mode=mode):
            return L.make_fisher_vector_product(policy, p, o, weights=w, damping=0.1, mode=mode)(v)

        fn = maybe_jit(fvp, use_jit)
        # Extra leading axes on obs (and weights) are flattened.
        got = ravel_pytree(fn(params, obs.reshape(2, 3, OBS), unravel(v), None))[0]
        np.testing.assert_allclose(got, f_mean @ v + 0.1 * v, rtol=1e-4, atol=1e-5)
        got = ravel_pytree(fn(params, obs, unravel(v), weights))[0]
        np.testing.assert_allclose(got, f_weighted @ v + 0.1 * v, rtol=1e-4, atol=1e-5)


def test_standalone_products_match_explicit():
    """The one-shot ``*_vector_product`` functions, as used without ``make_fisher_vector_product``."""
    policy, params, obs, flat, unravel, weights = setup("categorical")
    f = explicit_fisher_jacobian("categorical", weights)
    v = np.random.default_rng(3).normal(size=flat.size).astype(np.float32)
    old = policy.dist(params, obs)

    @jax.jit
    def products(v):
        gn = L.gauss_newton_vector_product(lambda p: policy.dist(p, obs), policy.fisher_metric, params, v, 0.5, weights)
        kl_fn = lambda p: jnp.sum(weights * policy.dist_kl(old, policy.dist(p, obs))) / jnp.sum(weights)
        return gn, L.kl_hessian_vector_product(kl_fn, params, v, 0.5)

    for got in products(unravel(v)):
        np.testing.assert_allclose(ravel_pytree(got)[0], f @ v + 0.5 * v, rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("name", ["gaussian", "categorical"])
def test_kl_with_itself_is_zero_with_zero_gradient(name):
    policy, params, obs, _, _, _ = setup(name)
    kl, grad = jax.jit(jax.value_and_grad(lambda p: jnp.mean(policy.kl(params, p, obs))))(params)
    assert abs(float(kl)) < 1e-6
    assert max(float(jnp.abs(g).max()) for g in jax.tree.leaves(grad)) < 1e-6


def test_cg_on_fisher_solves_natural_gradient():
    """``conjugate_gradient`` with a damped FVP reproduces ``(F + lambda I)^-1 g``."""
    policy, params, obs, flat, unravel, _ = setup("gaussian")
    f = explicit_fisher_jacobian("gaussian", np.ones(N)) + 0.1 * np.eye(flat.size)
    g = np.random.default_rng(2).normal(size=flat.size).astype(np.float32)
    fvp = L.make_fisher_vector_product(policy, params, obs, damping=0.1)
    res = jax.jit(lambda g: L.conjugate_gradient(fvp, g, iters=3 * flat.size))(unravel(g))
    np.testing.assert_allclose(ravel_pytree(res.x)[0], np.linalg.solve(f, g), rtol=2e-3, atol=2e-3)


def test_unknown_mode_raises():
    policy, params, obs, _, _, _ = setup("gaussian")
    with pytest.raises(ValueError):
        L.make_fisher_vector_product(policy, params, obs, mode="exact")
