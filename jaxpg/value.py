"""Fitting the value function by minibatch regression, entirely inside ``jit``.

LyceumAI's ``FluxTrainer`` (and mjrl's ``MLPBaseline``) refit the baseline every iteration with a
few epochs of minibatch Adam on the mean squared error to the value targets (LyceumAI: batch 64,
learning rate 1e-3, 3 epochs). Here every epoch's minibatches (a fresh permutation per epoch) are drawn first and
stepped through in one ``lax.scan``, so shapes are static and nothing returns to the host.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import optax

from jaxpg.policies import ValueFunction

Params = Any


def value_loss(
    value_fn: ValueFunction,
    params: Params,
    obs: jax.Array,
    targets: jax.Array,
    weights: jax.Array | None = None,
) -> jax.Array:
    """Mean squared error ``sum_i w_i (V(obs_i) - target_i)^2 / sum_i w_i``: ``[]``.

    ``obs: [..., obs_dim]``, ``targets: [...]``, ``weights: [...]`` (all ones if ``None``; a
    batch whose weights sum to zero has loss 0).
    """
    err = jnp.square(value_fn.apply(params, obs) - targets)
    if weights is None:
        return jnp.mean(err)
    w = jnp.asarray(weights, err.dtype)
    return jnp.sum(w * err) / jnp.maximum(jnp.sum(w), jnp.finfo(err.dtype).tiny)


def fit_value(
    value_fn: ValueFunction,
    params: Params,
    opt_state: optax.OptState,
    optimizer: optax.GradientTransformation,
    obs: jax.Array,
    targets: jax.Array,
    key: jax.Array,
    epochs: int,
    batch_size: int,
    weights: jax.Array | None = None,
    samples_per_epoch: int = 0,
) -> tuple[Params, optax.OptState, jax.Array]:
    """``epochs`` passes of minibatch ``optimizer`` steps on ``value_loss``.

    Each epoch draws a fresh permutation of the ``N`` samples and takes ``N // batch_size`` steps
    on disjoint minibatches (the remainder is dropped; ``batch_size`` larger than ``N`` is taken
    as ``N``). With ``0 < samples_per_epoch < N`` an epoch instead takes
    ``samples_per_epoch // batch_size`` steps on minibatches drawn uniformly with replacement, so
    that the fit's cost stops growing with the batch (and no ``N``-sized shuffle is needed).

    Args:
      obs: ``[N, obs_dim]``; targets: ``[N]``; weights: optional ``[N]`` (e.g. the ``valid`` mask).
      key: PRNG key for the shuffles.
      epochs, batch_size, samples_per_epoch: static.
    All ``epochs x num_batches`` minibatches are drawn first and stepped through in one loop.
    Returns ``(params, opt_state, mean_loss [])``, the loss averaged over all minibatch steps
    (each measured before its step; NaN when no step is taken).
    """
    n = obs.shape[0]
    batch_size = min(batch_size, n)
    subsample = 0 < samples_per_epoch < n
    num_batches = max(1, samples_per_epoch // batch_size) if subsample else n // batch_size
    w_all = jnp.ones((n,), targets.dtype) if weights is None else jnp.asarray(weights, targets.dtype)
    grad_fn = jax.value_and_grad(lambda p, o, t, w: value_loss(value_fn, p, o, t, w))

    def minibatch(carry: tuple, idx: jax.Array) -> tuple[tuple, jax.Array]:
        params, opt_state = carry
        loss, grads = grad_fn(params, obs[idx], targets[idx], w_all[idx])
        updates, opt_state = optimizer.update(grads, opt_state, params)
        return (optax.apply_updates(params, updates), opt_state), loss

    def epoch_indices(epoch_key: jax.Array) -> jax.Array:
        if subsample:
            return jax.random.randint(epoch_key, (num_batches, batch_size), 0, n)
        return jax.random.permutation(epoch_key, n)[: num_batches * batch_size].reshape(num_batches, batch_size)

    indices = jax.vmap(epoch_indices)(jax.random.split(key, epochs)).reshape(epochs * num_batches, batch_size)
    (params, opt_state), losses = jax.lax.scan(minibatch, (params, opt_state), indices)
    return params, opt_state, jnp.mean(losses)


def preserve_outputs(
    params: Params, old_mean: jax.Array, old_std: jax.Array, new_mean: jax.Array, new_std: jax.Array
) -> Params:
    """Rescale the output layer of an MLP value network (``[{"w": [in, 1], "b": [1]}, ...]``) that
    predicts standardised targets, so that its predictions in target units stay the same when the
    standardisation moves from ``(old_mean, old_std)`` to ``(new_mean, new_std)`` (all ``[]`` or
    ``[1]``): ``w' = w old_std / new_std``, ``b' = (old_std b + old_mean - new_mean) / new_std``.
    This is PopArt's "preserve outputs" step (van Hasselt et al., 2016).
    """
    last = params[-1]
    scale = old_std / new_std
    rescaled = {**last, "w": last["w"] * scale, "b": (old_std * last["b"] + old_mean - new_mean) / new_std}
    return [*params[:-1], rescaled]
