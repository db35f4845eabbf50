"""Action distributions as plain dicts of arrays, and pure functions on them.

A distribution is a pytree of its parameters, so it can be ``vmap``-ed, ``stop_gradient``-ed,
stored in a trajectory and differentiated through like any other array:

* diagonal Gaussian: ``{"mean": [..., A], "log_std": [..., A]}`` (``log_std`` broadcastable to
  ``mean``, e.g. a global ``[A]`` vector);
* categorical: ``{"logits": [..., K]}`` (unnormalised).

``*_fisher_metric(dist, tangent)`` applies the Fisher information matrix of the distribution *in its
own parameters* to a tangent with the distribution's structure. With ``J`` the Jacobian of the
distribution parameters with respect to the network parameters, the policy's Fisher matrix is
``E_s[J^T M J]`` (Martens, 2014; Schulman et al., 2015, appendix C), which ``jaxpg.linalg`` uses.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

Dist = dict[str, jax.Array]

_LOG_2PI = math.log(2.0 * math.pi)


# -- Diagonal Gaussian ---------------------------------------------------------------------------


def _gaussian_parts(dist: Dist) -> tuple[jax.Array, jax.Array]:
    """``mean`` and ``log_std``, both broadcast to their common shape ``[..., A]``."""
    mean, log_std = jnp.broadcast_arrays(dist["mean"], dist["log_std"])
    return mean, log_std


def gaussian_sample(dist: Dist, key: jax.Array) -> jax.Array:
    """``x = mean + exp(log_std) * eps``, ``eps ~ N(0, I)``: ``[..., A]``."""
    mean, log_std = _gaussian_parts(dist)
    eps = jax.random.normal(key, mean.shape, mean.dtype)
    return mean + jnp.exp(log_std) * eps


def gaussian_log_prob(dist: Dist, x: jax.Array) -> jax.Array:
    """``log N(x; mean, diag(std^2)) = sum_i -((x_i - mu_i)/sigma_i)^2 / 2 - log sigma_i - log(2 pi)/2``.

    ``x: [..., A] -> [...]``.
    """
    mean, log_std = _gaussian_parts(dist)
    z = (x - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * jnp.square(z) - log_std - 0.5 * _LOG_2PI, axis=-1)


def gaussian_entropy(dist: Dist) -> jax.Array:
    """``H = sum_i log sigma_i + log(2 pi e)/2``: ``[...]``."""
    _, log_std = _gaussian_parts(dist)
    return jnp.sum(log_std + 0.5 * (_LOG_2PI + 1.0), axis=-1)


def gaussian_kl(p: Dist, q: Dist) -> jax.Array:
    """``KL(p || q) = sum_i log(s_q/s_p) + (s_p^2 + (mu_p - mu_q)^2) / (2 s_q^2) - 1/2``: ``[...]``."""
    mean_p, log_std_p = _gaussian_parts(p)
    mean_q, log_std_q = _gaussian_parts(q)
    ratio_var = jnp.exp(2.0 * (log_std_p - log_std_q))
    mahalanobis = jnp.square((mean_p - mean_q) * jnp.exp(-log_std_q))
    return jnp.sum(log_std_q - log_std_p + 0.5 * (ratio_var + mahalanobis - 1.0), axis=-1)


def gaussian_mode(dist: Dist) -> jax.Array:
    """The most likely action, the mean: ``[..., A]``."""
    mean, _ = _gaussian_parts(dist)
    return mean


def gaussian_clipped_mean(dist: Dist, low: float, high: float) -> jax.Array:
    """``E[clip(x, low, high)]`` for ``x ~ N(mean, diag(std^2))``, per dimension: ``[..., A]``.

    The mean of the actions a task that clips them (``low < high``) executes, which a wide
    policy's ``clip(mean)`` is not. With ``a = (low - mu) / sigma``, ``b = (high - mu) / sigma``
    and the standard normal's ``Phi`` and ``phi``:
    ``low Phi(a) + high (1 - Phi(b)) + mu (Phi(b) - Phi(a)) + sigma (phi(a) - phi(b))``.
    """
    mean, log_std = _gaussian_parts(dist)
    sigma = jnp.exp(log_std)
    a, b = (low - mean) / sigma, (high - mean) / sigma
    cdf = lambda z: 0.5 * (1.0 + jax.lax.erf(z / math.sqrt(2.0)))  # noqa: E731 - the standard normal's
    pdf = lambda z: jnp.exp(-0.5 * jnp.square(z) - 0.5 * _LOG_2PI)  # noqa: E731
    cdf_a, cdf_b = cdf(a), cdf(b)
    inside = mean * (cdf_b - cdf_a) + sigma * (pdf(a) - pdf(b))
    return jnp.clip(low * cdf_a + high * (1.0 - cdf_b) + inside, low, high)


def gaussian_fisher_metric(dist: Dist, tangent: Dist) -> Dist:
    """Fisher information in ``(mean, log_std)`` applied to ``tangent``.

    The Fisher matrix of ``N(mu, diag(exp(2 log_sigma)))`` is block diagonal with ``diag(1/sigma^2)``
    for the mean and ``2 I`` for the log-std, so ``{"mean": t_mu / sigma^2, "log_std": 2 t_ls}``.
    """
    inv_var = jnp.exp(-2.0 * jnp.asarray(dist["log_std"]))
    return {"mean": tangent["mean"] * inv_var, "log_std": 2.0 * tangent["log_std"]}


# -- Categorical ---------------------------------------------------------------------------------


def categorical_sample(dist: Dist, key: jax.Array) -> jax.Array:
    """An index drawn with probabilities ``softmax(logits)``: int32 ``[...]``."""
    return jax.random.categorical(key, dist["logits"], axis=-1).astype(jnp.int32)


def categorical_log_prob(dist: Dist, x: jax.Array) -> jax.Array:
    """``log softmax(logits)[x]`` for integer actions ``x: [...] -> [...]``."""
    log_p = jax.nn.log_softmax(dist["logits"], axis=-1)
    x = jnp.asarray(x).astype(jnp.int32)
    return jnp.take_along_axis(log_p, x[..., None], axis=-1)[..., 0]


def categorical_entropy(dist: Dist) -> jax.Array:
    """``H = -sum_k p_k log p_k``: ``[...]``."""
    log_p = jax.nn.log_softmax(dist["logits"], axis=-1)
    return -jnp.sum(jnp.exp(log_p) * log_p, axis=-1)


def categorical_kl(p: Dist, q: Dist) -> jax.Array:
    """``KL(p || q) = sum_k p_k (log p_k - log q_k)``: ``[...]``."""
    log_p = jax.nn.log_softmax(p["logits"], axis=-1)
    log_q = jax.nn.log_softmax(q["logits"], axis=-1)
    return jnp.sum(jnp.exp(log_p) * (log_p - log_q), axis=-1)


def categorical_mode(dist: Dist) -> jax.Array:
    """The most likely action ``argmax_k logits_k``: int32 ``[...]``."""
    return jnp.argmax(dist["logits"], axis=-1).astype(jnp.int32)


def categorical_fisher_metric(dist: Dist, tangent: Dist) -> Dist:
    """Fisher information in the logits applied to ``tangent``: ``(diag(p) - p p^T) t``.

    Computed as ``p * t - p (p . t)`` without forming the ``[K, K]`` matrix.
    """
    p = jax.nn.softmax(dist["logits"], axis=-1)
    t = tangent["logits"]
    return {"logits": p * t - p * jnp.sum(p * t, axis=-1, keepdims=True)}
