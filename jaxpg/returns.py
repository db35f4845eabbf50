"""Returns, advantages and their normalisation on time-major ``[T, B]`` batches.

Conventions (those of ``jaxpg.rollout.Trajectory``): ``terminated[t]`` means the task ended at
step ``t`` and the value after it is zero; ``truncated[t]`` means the time limit cut the episode at
``t`` and the value of ``next_obs[t]`` should be bootstrapped; a step with either is *done*, and
the next row of that env column starts a new episode. Where both flags are set, termination wins.
All functions are pure and jittable. The reverse recursions (returns, GAE) are linear,
``y_t = x_t + c_t y_{t+1}``: by default a reverse ``lax.scan``; with ``parallel=True`` a
``lax.associative_scan`` (a tree of ``O(log T)`` whole-batch steps, the same numbers up to float
rounding). On a GPU GAE alone runs faster in the associative form but compiles longer, and in the
card's whole training iteration the difference was within noise (docs/benchmarks_archive.md,
section AE), so the scan stays the default.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

ArrayLike = jax.Array | float


def reverse_linear_recurrence(inputs: jax.Array, coeffs: jax.Array, last: jax.Array | None = None) -> jax.Array:
    """``y_t = inputs_t + coeffs_t y_{t+1}`` for ``t = T-1 .. 0`` with ``y_T = last`` (zeros if
    ``None``), by ``lax.associative_scan`` over the leading axis: ``[T, ...]``.

    ``inputs, coeffs: [T, ...]``; ``last: [...]``. Composing the affine maps ``y -> x + c y`` is
    associative, so the ``T`` steps become a tree of ``O(log T)`` elementwise steps over the
    whole array instead of ``T`` sequential ones.
    """
    if last is not None:
        inputs = inputs.at[-1].add(coeffs[-1] * last)

    def compose(later: tuple[jax.Array, jax.Array], earlier: tuple[jax.Array, jax.Array]) -> tuple:
        # scanning backwards in time: `later` already holds the composed maps of later steps
        c_later, x_later = later
        c_earlier, x_earlier = earlier
        return c_earlier * c_later, x_earlier + c_earlier * x_later

    return jax.lax.associative_scan(compose, (coeffs, inputs), reverse=True)[1]


def discounted_returns(
    rewards: jax.Array,
    terminated: jax.Array,
    truncated: jax.Array,
    gamma: ArrayLike,
    next_values: jax.Array | None = None,
    parallel: bool = False,
) -> jax.Array:
    """Reward-to-go ``G_t = r_t + gamma G_{t+1}`` within each episode: ``[T, B]``.

    The recursion stops at done steps. With ``next_values`` ``[T, B]`` (the value of ``next_obs``)
    a truncated step ends with ``G_t = r_t + gamma V(next_obs_t)`` and the last row, if not done,
    bootstraps ``G_{T-1} = r_{T-1} + gamma V(next_obs_{T-1})``; a terminated step ends with
    ``G_t = r_t``. Without ``next_values`` nothing is bootstrapped (Monte-Carlo returns, REINFORCE,
    Williams 1992).

    Args:
      rewards: ``[T, B]``.
      terminated, truncated: ``[T, B]`` bool.
      gamma: discount factor.
      next_values: optional ``[T, B]`` ``V(next_obs)``.
      parallel: static; ``reverse_linear_recurrence`` instead of the sequential ``lax.scan``.
    """
    rewards = jnp.asarray(rewards)
    terminated = jnp.asarray(terminated, bool)
    truncated = jnp.asarray(truncated, bool)
    if next_values is None:
        next_values = jnp.zeros_like(rewards)
    done = terminated | truncated
    # Value after a done step: V(next_obs) when truncated, 0 when terminated.
    end_values = jnp.where(truncated & ~terminated, next_values, 0.0)
    if parallel:
        inputs = rewards + gamma * end_values  # end_values is 0 wherever the step is not done
        return reverse_linear_recurrence(inputs, gamma * (1.0 - done.astype(inputs.dtype)), next_values[-1])

    def step(future: jax.Array, xs: tuple[jax.Array, ...]) -> tuple[jax.Array, jax.Array]:
        r, d, end = xs
        g = r + gamma * jnp.where(d, end, future)
        return g, g

    _, returns = jax.lax.scan(step, next_values[-1], (rewards, done, end_values), reverse=True)
    return returns


def gae(
    rewards: jax.Array,
    values: jax.Array,
    next_values: jax.Array,
    terminated: jax.Array,
    truncated: jax.Array,
    gamma: ArrayLike,
    lam: ArrayLike,
    parallel: bool = False,
    *,
    gamma_lambda: ArrayLike | None = None,
) -> tuple[jax.Array, jax.Array]:
    """Generalised advantage estimation (Schulman et al., 2016, eq. 16).

    ``delta_t = r_t + gamma (1 - terminated_t) V(next_obs_t) - V(obs_t)`` and
    ``A_t = delta_t + gamma lam (1 - done_t) A_{t+1}`` with ``A_T = 0``: a truncated step
    bootstraps through ``V(next_obs_t)`` but does not carry the next episode's advantages, and the
    last row bootstraps through ``next_values[T-1]``.

    Args:
      rewards, values, next_values: ``[T, B]``; ``values = V(obs)``, ``next_values = V(next_obs)``.
      terminated, truncated: ``[T, B]`` bool.
      gamma, lam: discount and GAE lambda.
      parallel: static; ``reverse_linear_recurrence`` instead of the sequential ``lax.scan``.
      gamma_lambda: ``gamma * lam`` computed elsewhere (a sweep's traced hyperparameters take the
        host's product, as a constant program folds it); default: the product here.
    Returns ``(advantages [T, B], value_targets [T, B])`` with ``value_targets = advantages + values``
    (the TD(lambda) returns).
    """
    terminated = jnp.asarray(terminated, bool)
    done = terminated | jnp.asarray(truncated, bool)
    # gamma multiplies before the select that zeroes terminated steps (the same numbers): with a
    # traced gamma this order keeps XLA from fusing its product and sum into one rounding where a
    # constant gamma's program rounds twice, so both compute the same bits.
    deltas = rewards + jnp.where(terminated, 0.0, gamma * next_values) - values
    carry_on = (gamma * lam if gamma_lambda is None else gamma_lambda) * (1.0 - done.astype(deltas.dtype))
    if parallel:
        advantages = reverse_linear_recurrence(deltas, carry_on)
        return advantages, advantages + values

    def step(next_adv: jax.Array, xs: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
        delta, c = xs
        adv = delta + c * next_adv
        return adv, adv

    _, advantages = jax.lax.scan(step, jnp.zeros_like(deltas[-1]), (deltas, carry_on), reverse=True)
    return advantages, advantages + values


def _all_equal(x: jax.Array, valid: jax.Array | None = None, segments: jax.Array | None = None) -> jax.Array:
    """Whether the entries of ``x`` (those where ``valid``, same shape, is set) are all one finite
    value: ``[]`` bool. False when there are none, or when one is NaN or infinite.

    With ``segments`` (int, same shape as ``x``, ids in ``[0, x.size)``) the question is asked of
    each segment's entries instead, and the answer comes back per entry: bool shaped like ``x``.
    """
    high_in = x if valid is None else jnp.where(valid, x, -jnp.inf)
    low_in = x if valid is None else jnp.where(valid, x, jnp.inf)
    if segments is None:
        high, low = jnp.max(high_in), jnp.min(low_in)
    else:
        ids = segments.reshape(-1)
        high = jax.ops.segment_max(high_in.reshape(-1), ids, num_segments=x.size)[ids].reshape(x.shape)
        low = jax.ops.segment_min(low_in.reshape(-1), ids, num_segments=x.size)[ids].reshape(x.shape)
    return (high == low) & jnp.isfinite(high)


def normalize(x: jax.Array, mask: jax.Array | None = None, eps: float = 1e-8) -> jax.Array:
    """``(x - mean) / (std + eps)`` over all entries (population std).

    With ``mask`` (same shape, bool or 0/1) the statistics use only the entries where it is set
    and the others come out as 0. Entries that are all equal (and finite) have no spread and come
    out as 0: their float32 mean can miss them by a rounding error, which the division would
    otherwise blow up to values of size 1.
    """
    if mask is None:
        return jnp.where(_all_equal(x), 0.0, (x - jnp.mean(x)) / (jnp.std(x) + eps))
    m = jnp.asarray(mask, x.dtype)
    n = jnp.maximum(jnp.sum(m), 1.0)
    mean = jnp.sum(x * m) / n
    std = jnp.sqrt(jnp.sum(m * jnp.square(x - mean)) / n)
    valid = m > 0
    return jnp.where(valid & ~_all_equal(x, valid), (x - mean) / (std + eps), 0.0)


def episode_ids(terminated: jax.Array, truncated: jax.Array) -> jax.Array:
    """``[T, B]`` int32: the index of each step's episode within its env column (0, 1, ...).

    The done step belongs to the episode it ends; the next row starts the next episode.
    """
    done = (jnp.asarray(terminated, bool) | jnp.asarray(truncated, bool)).astype(jnp.int32)
    return jnp.cumsum(done, axis=0) - done


def normalize_per_episode(
    values: jax.Array,
    terminated: jax.Array,
    truncated: jax.Array,
    valid: jax.Array | None = None,
    eps: float = 1e-8,
) -> jax.Array:
    """Normalise ``values`` by the mean and (population) std of their own episode: ``[T, B]``.

    ``(v - mean_e) / (std_e + eps)`` where ``e`` is the step's episode, a contiguous segment of its
    env column ended by a done step (the last one may be unfinished). This is the per-episode
    return normalisation of the Kokoyi and MinPy policy-gradient examples (Karpathy's "Pong from
    pixels"). Steps where ``valid`` is 0 take no part in the statistics and come out as 0. An
    episode whose (valid) values are all equal and finite has no spread and comes out as 0: its
    float32 mean can miss them by a rounding error, which the division would otherwise blow up to
    values of size 1.
    """
    T, B = values.shape
    w = jnp.ones_like(values) if valid is None else jnp.asarray(valid, values.dtype)
    # One segment per (column, episode); a column holds at most T episodes.
    segments = episode_ids(terminated, truncated) + T * jnp.arange(B)[None, :]
    seg = segments.reshape(-1)

    def seg_sum(x: jax.Array) -> jax.Array:
        return jax.ops.segment_sum(x.reshape(-1), seg, num_segments=T * B)[seg].reshape(T, B)

    n = jnp.maximum(seg_sum(w), 1.0)
    mean = seg_sum(w * values) / n
    std = jnp.sqrt(seg_sum(w * jnp.square(values - mean)) / n)
    is_valid = w > 0
    spread = ~_all_equal(values, is_valid, segments)
    return jnp.where(is_valid & spread, (values - mean) / (std + eps), 0.0)
