"""The training batch every algorithm learns from, and means over its valid samples: the KL
between two policies and the policy's entropy.

A sampled ``Trajectory`` is time-major, ``[T, B, ...]``; the batch is flat, ``[N = B * T, ...]``,
env-major (``jaxpg.rollout.flatten_samples``): an algorithm builds its ``Batch`` time-major and
flattens it once with ``flatten_batch``, so that the rows of every field line up.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from jaxpg.algos.core.state import TrainState
from jaxpg.rollout import flatten_samples


@struct.dataclass
class Batch:
    """One iteration's training batch, ``[N, ...]`` on every field (``[T, B, ...]`` before
    ``flatten_batch``).

    Attributes:
      obs: ``[N, obs_dim]`` observations, normalised with the statistics they were sampled with.
      actions: ``[N, act_dim]`` (continuous) or ``[N]`` int32 (discrete).
      log_probs: ``[N]`` log-probability of the action under the sampling policy.
      advantages: ``[N]`` what the policy gradient weighs each action's score with.
      value_targets: ``[N]`` what the value network (if any) is fitted to.
      weights: ``[N]`` the validity mask (0 for padding steps of episodic sampling).
    """

    obs: jax.Array
    actions: jax.Array
    log_probs: jax.Array
    advantages: jax.Array
    value_targets: jax.Array
    weights: jax.Array


def flatten_batch(batch: Batch) -> Batch:
    """``[T, B, ...] -> [B * T, ...]`` on every field, env-major (``flatten_samples``)."""
    return jax.tree.map(flatten_samples, batch)


def weighted_mean(x: jax.Array, weights: jax.Array) -> jax.Array:
    """``[]`` mean of ``x`` over the samples ``weights`` selects (any matching shapes)."""
    return jnp.sum(x * weights) / jnp.maximum(jnp.sum(weights), 1.0)


def mean_kl(ts: TrainState, old_params: Any, new_params: Any, batch: Batch) -> jax.Array:
    """``[]`` mean KL(pi_old || pi_new) over the valid samples of ``batch``."""
    kl = ts.policy.kl(old_params, new_params, batch.obs)
    return weighted_mean(kl, batch.weights)


def mean_entropy(ts: TrainState, params: Any, batch: Batch) -> jax.Array:
    """``[]`` mean entropy of the policy ``params`` over the valid samples of ``batch``."""
    return weighted_mean(ts.policy.entropy(params, batch.obs), batch.weights)
