"""Advantages and value targets from the value function: GAE (Schulman et al. 2016) by default,
any ``AdvantageFn`` on request, normalised and flattened into the training ``Batch``."""

from __future__ import annotations

import functools
from collections.abc import Callable

import jax

from jaxpg import returns
from jaxpg.algos.core.batch import Batch, flatten_batch
from jaxpg.algos.core.hparams import derived, is_traced, run_config
from jaxpg.algos.core.state import TrainState
from jaxpg.rollout import Trajectory

AdvantageFn = Callable[[TrainState, Trajectory, jax.Array, jax.Array], tuple[jax.Array, jax.Array]]
"""``(ts, traj, values, next_values) -> (advantages, value_targets)``, every array ``[T, B]``."""


def value_predictions(ts: TrainState, obs: jax.Array) -> jax.Array:
    """``V(obs)`` in return units, ``[...]`` for normalised ``obs [..., obs_dim]``: the network's
    output, de-standardised by ``ts.value_stats`` when ``config.normalize_value_targets`` is set."""
    out = ts.value_fn.apply(ts.value_params, obs)
    if ts.config.normalize_value_targets:
        out = ts.value_stats.mean[0] + ts.value_stats.std[0] * out
    return out


def gae_advantages(
    ts: TrainState, traj: Trajectory, values: jax.Array, next_values: jax.Array, parallel: bool = False
) -> tuple[jax.Array, jax.Array]:
    """The default ``AdvantageFn``: GAE(gamma, gae_lambda) advantages and the value targets
    ``config.value_target`` selects (the lambda-returns, or discounted returns bootstrapped where
    an episode was truncated), all ``[T, B]``.

    ``values`` and ``next_values`` are ``V(obs)`` and ``V(next_obs)`` of ``traj`` in return units
    (``value_predictions``), computed once by ``phase_advantages``. ``parallel`` computes both
    recurrences as associative scans (``returns.gae(..., parallel=True)``: the same numbers to
    float rounding); bind it with ``functools.partial`` to get an ``AdvantageFn`` for
    ``npg.make_update``.
    """
    config = run_config(ts)
    gae = returns.gae
    if is_traced(ts):
        gae = functools.partial(returns.gae, gamma_lambda=derived(ts, "gamma*gae_lambda"))
    advantages, targets = gae(
        traj.rewards,
        values,
        next_values,
        traj.terminated,
        traj.truncated,
        config.gamma,
        config.gae_lambda,
        parallel=parallel,
    )
    if ts.config.value_target == "returns":
        targets = returns.discounted_returns(
            traj.rewards,
            traj.terminated,
            traj.truncated,
            config.gamma,
            next_values=next_values,
            parallel=parallel,
        )
    return advantages, targets


def phase_advantages(ts: TrainState, traj: Trajectory, advantage_fn: AdvantageFn = gae_advantages) -> Batch:
    """The training ``Batch`` of ``traj``: advantages and value targets from the current value
    function (GAE unless ``advantage_fn`` says otherwise), the advantages standardised over the
    valid samples when ``config.normalize_advantages`` (a ``GAEConfig``), all flattened env-major
    (``flatten_batch``)."""
    obs = ts.obs_stats.normalize(traj.obs)
    next_obs = ts.obs_stats.normalize(traj.next_obs)
    values = value_predictions(ts, obs)
    next_values = value_predictions(ts, next_obs)
    advantages, targets = advantage_fn(ts, traj, values, next_values)
    if ts.config.normalize_advantages:
        advantages = returns.normalize(advantages, mask=traj.valid)
    return flatten_batch(
        Batch(
            obs=obs,
            actions=traj.actions,
            log_probs=traj.log_probs,
            advantages=advantages,
            value_targets=targets,
            weights=traj.valid,
        )
    )
