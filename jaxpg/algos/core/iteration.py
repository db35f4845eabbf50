"""How an iteration is made of named phases, and the end of every iteration: the guard that rolls
back a non-finite update or one that left the trust region, the observation statistics, the
iteration count and the metrics.

An algorithm writes its iteration once, as ``iteration(ts, run_phase=run_inline)``, calling each
phase through ``run_phase(name, fn, *args)`` and listing the names in its ``PHASES``; its
``update(ts)`` is ``iteration(ts)``. Inside jit the phases run inline (``run_inline``); the
profiler (``jaxpg.run.host.profiling``) hands a ``run_phase`` that jits and times each phase, and the
benchmarks one that stops after a given phase. ``fn``'s array inputs are all in ``args``, so that
``fn`` may be jitted on its own.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.algos.core.hparams import run_config
from jaxpg.algos.core.log_std_bounds import clip_log_std
from jaxpg.algos.core.sampling import sampling_metrics
from jaxpg.algos.core.state import TrainState
from jaxpg.rollout import Trajectory

PhaseRunner = Callable[..., Any]
"""``run_phase(name, fn, *args) -> fn(*args)``: how an iteration runs its phase ``name``."""


def run_inline(name: str, fn: Callable[..., Any], *args: Any) -> Any:
    """The ``PhaseRunner`` of ``update``: ``fn(*args)``, traced into the one fused iteration."""
    del name
    return fn(*args)


def all_finite(tree: Any) -> jax.Array:
    """``[]`` bool: every floating leaf of ``tree`` is finite."""
    leaves = [
        jnp.all(jnp.isfinite(x)) for x in jax.tree.leaves(tree) if jnp.issubdtype(jnp.asarray(x).dtype, jnp.inexact)
    ]
    return jnp.all(jnp.stack(leaves)) if leaves else jnp.array(True)


def accept_if_finite(
    old: TrainState, new: TrainState, loss: jax.Array, within_trust_region: jax.Array | bool = True
) -> tuple[TrainState, jax.Array]:
    """Keep ``new`` when its parameters, optimizer states and ``loss`` are finite (and the update
    stayed ``within_trust_region``), else roll the learned state back to ``old`` (the sampling
    state still advances). Non-finite updates count as consecutive failures; a rolled-back
    trust-region violation does not (the policy is intact).

    Returns the state to continue with and ``[]`` float32 1.0 where the update was rejected.
    """
    learned = (new.params, new.value_params, new.opt_state, new.value_opt_state, new.value_stats)
    finite = all_finite(learned) & jnp.isfinite(loss)
    ok = finite & jnp.asarray(within_trust_region)
    old_learned = (old.params, old.value_params, old.opt_state, old.value_opt_state, old.value_stats)
    params, value_params, opt_state, value_opt_state, value_stats = jax.tree.map(
        lambda n, o: jnp.where(ok, n, o), learned, old_learned
    )
    failures = jnp.where(finite, 0, new.failures + 1)
    state = new.replace(
        params=params,
        value_params=value_params,
        opt_state=opt_state,
        value_opt_state=value_opt_state,
        value_stats=value_stats,
        failures=failures,
    )
    return state, (~ok).astype(jnp.float32)


def finish_iteration(
    old: TrainState,
    new: TrainState,
    traj: Trajectory,
    *,
    loss: jax.Array,
    kl: jax.Array,
    metrics: dict[str, jax.Array],
    step_accepted: jax.Array | bool = True,
) -> tuple[TrainState, dict[str, jax.Array]]:
    """The common end of an iteration that started from ``old``, sampled ``traj`` and learned
    ``new``: reject the update when it is non-finite (``loss`` or any learned array), when its mean
    KL(old || new) ``kl`` exceeds ``config.max_update_kl`` (when set), or when the algorithm did
    not accept its own step (``step_accepted``, e.g. NPG's backtracking found no step within its
    bound); then hold the policy's log-std within its floor and falling ceiling
    (``core.clip_log_std``, when ``log_std_min`` or ``anneal_log_std_iterations`` is set), update
    the observation statistics with ``traj`` and count the iteration.

    Returns the state to continue with and the iteration's metrics: the sampling metrics, the
    algorithm's ``metrics``, ``kl``, ``update_rejected`` and ``consecutive_failures``, all ``[]``.
    The mean policy is not evaluated here: evaluation runs between compiled training calls
    (``jaxpg.train.evaluate_state``).
    """
    within = (kl <= run_config(new).max_update_kl) if new.config.max_update_kl > 0 else True
    within = jnp.logical_and(within, step_accepted)
    ts, rejected = accept_if_finite(old, new, loss, within)
    ts = clip_log_std(ts, old.iteration + 1)
    if ts.config.normalize_observations:
        ts = ts.replace(obs_stats=ts.obs_stats.update(traj.obs, traj.valid))
    all_metrics = {
        **sampling_metrics(old, traj),
        **metrics,
        "kl": kl,
        "update_rejected": rejected,
        "consecutive_failures": ts.failures.astype(jnp.float32),
    }
    return ts.replace(iteration=ts.iteration + 1), all_metrics
