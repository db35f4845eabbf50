"""Fisher-vector products and conjugate gradient, on pytree vectors.

Natural policy gradient (Kakade, 2001) and TRPO (Schulman et al., 2015) solve ``F x = g`` with
``F`` the Fisher information matrix of the policy, averaged over the sampled states, without ever
forming ``F``: conjugate gradient only needs products ``F v``. Two ways to compute them:

* ``kl_hessian_vector_product``: ``F = Hessian of mean KL(pi_fixed || pi_theta)`` at
  ``theta = fixed``, differentiated forward-over-reverse (a ``jvp`` of a ``grad``), as mjrl and
  the TRPO reference code do;
* ``gauss_newton_vector_product``: ``F = J^T M J / N`` with ``J`` the Jacobian of the
  distribution parameters in the network parameters and ``M`` the distribution's analytic Fisher
  metric (Martens, 2014; Schulman et al., 2015, appendix C) -- one ``jvp`` and one ``vjp``, no
  second derivatives.

Both are exact (not sampled) and agree; vectors may be any pytree shaped like ``params``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

PyTree = Any


def tree_vdot(a: PyTree, b: PyTree) -> jax.Array:
    """``<a, b>``: the sum over leaves of the elementwise products, ``[]``."""
    return sum((jnp.vdot(x, y) for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True)), jnp.zeros(()))


def tree_axpy(alpha: jax.Array, x: PyTree, y: PyTree) -> PyTree:
    """``alpha * x + y`` leafwise."""
    return jax.tree.map(lambda u, v: alpha * u + v, x, y)


@struct.dataclass
class CGResult:
    """Result of ``conjugate_gradient``.

    Attributes:
      x: the approximate solution, shaped like ``b``.
      residual_norm: ``[]`` ``||b - A x||`` as tracked by the CG recursion (equal to the true
        residual in exact arithmetic).
      iterations: ``[]`` int32, the iterations that changed ``x`` (at most ``iters``).
    """

    x: PyTree
    residual_norm: jax.Array
    iterations: jax.Array


def conjugate_gradient(
    matvec: Callable[[PyTree], PyTree], b: PyTree, iters: int, residual_tol: float = 0.0
) -> CGResult:
    """Solve ``A x = b`` for symmetric positive-definite ``A`` given as ``matvec(v) = A v``.

    Conjugate gradient (Hestenes & Stiefel, 1952; Nocedal & Wright, algorithm 5.2) from ``x_0 = 0``:
    ``alpha = r.r / p.Ap``, ``x += alpha p``, ``r -= alpha A p``, ``p = r + (r'.r' / r.r) p``.
    Runs exactly ``iters`` loop steps (a ``lax.fori_loop``, so it compiles once and never syncs
    with the host); once ``||r|| <= residual_tol`` (or if ``p.Ap <= 0``) the iterate is frozen and
    later steps are no-ops. ``b`` and ``x`` are pytrees of the same structure.
    """
    x = jax.tree.map(jnp.zeros_like, b)
    rdotr = tree_vdot(b, b)

    def body(_: int, state: tuple) -> tuple:
        x, r, p, rdotr, count = state
        z = matvec(p)
        p_z = tree_vdot(p, z)
        # Converged, or no positive curvature along p (A singular there): keep x as it is.
        active = (jnp.sqrt(rdotr) > residual_tol) & (rdotr > 0.0) & (p_z > 0.0)
        alpha = jnp.where(active, rdotr / jnp.where(active, p_z, 1.0), 0.0)
        x = tree_axpy(alpha, p, x)
        r = tree_axpy(-alpha, z, r)
        new_rdotr = jnp.where(active, tree_vdot(r, r), rdotr)
        beta = new_rdotr / jnp.where(active, rdotr, 1.0)
        p = jax.tree.map(lambda r_, p_: jnp.where(active, r_ + beta * p_, p_), r, p)
        return x, r, p, new_rdotr, count + active.astype(jnp.int32)

    state = (x, b, b, rdotr, jnp.zeros((), jnp.int32))
    x, _, _, rdotr, count = jax.lax.fori_loop(0, iters, body, state)
    return CGResult(x=x, residual_norm=jnp.sqrt(rdotr), iterations=count)


def kl_hessian_operator(
    kl_fn: Callable[[PyTree], jax.Array], params: PyTree, damping: float = 0.0
) -> Callable[[PyTree], PyTree]:
    """``v -> (H + damping I) v`` with ``H`` the Hessian of ``kl_fn`` at ``params``.

    ``grad(kl_fn)`` is linearised once (``jax.linearize``), so that each product -- e.g. each
    conjugate-gradient step -- costs only the linear forward-over-reverse pass.
    """
    _, hvp = jax.linearize(jax.grad(kl_fn), params)
    return lambda v: tree_axpy(damping, v, hvp(v))


def kl_hessian_vector_product(
    kl_fn: Callable[[PyTree], jax.Array], params: PyTree, v: PyTree, damping: float = 0.0
) -> PyTree:
    """``(H + damping I) v`` with ``H`` the Hessian of ``kl_fn`` at ``params``.

    ``kl_fn(params) -> []`` is the mean ``KL(pi_fixed || pi_params)`` with the first argument held
    fixed (``stop_gradient``); at ``params = fixed`` its Hessian is the Fisher matrix. Computed
    forward-over-reverse: ``jvp(grad(kl_fn), params, v)``.
    """
    _, hv = jax.jvp(jax.grad(kl_fn), (params,), (v,))
    return tree_axpy(damping, v, hv)


def _weighted_mean_factor(leaf: jax.Array, weights: jax.Array | None) -> jax.Array:
    """Per-sample factor ``w_i / sum(w)`` (or ``1/N``) broadcast against ``leaf [N, ...]``."""
    if weights is None:
        return jnp.asarray(1.0 / leaf.shape[0], leaf.dtype)
    w = jnp.asarray(weights, leaf.dtype)
    w = w / jnp.maximum(jnp.sum(w), jnp.finfo(leaf.dtype).tiny)
    return w.reshape(w.shape + (1,) * (leaf.ndim - w.ndim))


def gauss_newton_operator(
    dist_fn: Callable[[PyTree], PyTree],
    metric_fn: Callable[[PyTree, PyTree], PyTree],
    params: PyTree,
    damping: float = 0.0,
    weights: jax.Array | None = None,
) -> Callable[[PyTree], PyTree]:
    """``v -> (J^T M J / N + damping I) v`` (see ``gauss_newton_vector_product``).

    ``dist_fn`` is linearised and its VJP built once, so that each product costs only one
    linear forward (``J v``) and one linear backward (``J^T u``) pass, without re-running the
    network.
    """
    dist, jvp_fn = jax.linearize(dist_fn, params)
    _, vjp_fn = jax.vjp(dist_fn, params)
    dist = jax.lax.stop_gradient(dist)

    def fvp(v: PyTree) -> PyTree:
        mjv = metric_fn(dist, jvp_fn(v))
        mjv = jax.tree.map(lambda t: t * _weighted_mean_factor(t, weights), mjv)
        (fv,) = vjp_fn(mjv)
        return tree_axpy(damping, v, fv)

    return fvp


def gauss_newton_vector_product(
    dist_fn: Callable[[PyTree], PyTree],
    metric_fn: Callable[[PyTree, PyTree], PyTree],
    params: PyTree,
    v: PyTree,
    damping: float = 0.0,
    weights: jax.Array | None = None,
) -> PyTree:
    """``(J^T M J / N + damping I) v``, the Fisher matrix of the policy times ``v``.

    ``dist_fn(params)`` returns the distribution parameters with leading sample axis ``[N, ...]``
    on every leaf (or ``weights.shape`` as leading axes when given); ``J`` is its Jacobian in
    ``params`` and ``M = metric_fn(dist, .)`` the per-sample Fisher metric of the distribution in
    its own parameters (``policy.fisher_metric``). Since ``E_a[score score^T] = J^T M J`` per
    state, this is exactly the Fisher matrix ``F = E_s E_a[grad log pi grad log pi^T]`` averaged
    over the ``N`` states -- a weighted mean ``sum_i w_i (.)_i / sum_i w_i`` with ``weights``.
    """
    return gauss_newton_operator(dist_fn, metric_fn, params, damping, weights)(v)


def make_fisher_vector_product(
    policy: Any,
    params: PyTree,
    obs: jax.Array,
    weights: jax.Array | None = None,
    damping: float = 0.0,
    mode: str = "gauss_newton",
) -> Callable[[PyTree], PyTree]:
    """``v -> (F + damping I) v`` for ``policy`` at ``params`` on the states ``obs [..., obs_dim]``.

    ``weights [...]`` (e.g. the trajectory's ``valid`` mask) make ``F`` a weighted mean over states.
    ``mode="gauss_newton"`` uses ``gauss_newton_operator``; ``mode="kl_hessian"`` the Hessian of the
    mean ``KL(stop_gradient(pi_params) || pi_theta)`` at ``theta = params``. The network is
    linearised here, once: build the product outside the conjugate-gradient loop.
    """
    obs = obs.reshape(-1, obs.shape[-1])
    w = None if weights is None else jnp.reshape(weights, (-1,))

    def dist_fn(p: PyTree) -> PyTree:
        return policy.dist(p, obs)

    if mode == "gauss_newton":
        return gauss_newton_operator(dist_fn, policy.fisher_metric, params, damping, w)
    if mode == "kl_hessian":
        dist_old = jax.lax.stop_gradient(dist_fn(params))

        def kl_fn(p: PyTree) -> jax.Array:
            kl = policy.dist_kl(dist_old, dist_fn(p))
            if w is None:
                return jnp.mean(kl)
            return jnp.sum(kl * w) / jnp.maximum(jnp.sum(w), jnp.finfo(kl.dtype).tiny)

        return kl_hessian_operator(kl_fn, params, damping)
    raise ValueError(f"unknown Fisher-vector product mode {mode!r}; expected 'gauss_newton' or 'kl_hessian'")
