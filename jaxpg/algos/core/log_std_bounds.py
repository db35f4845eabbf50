"""Bounds on a Gaussian policy's learned global log-std: a floor, and a ceiling that may fall.

At the end of every iteration (``core.finish_iteration``) the ``gaussian`` policy's log-std vector
is clipped to ``[log_std_min, ceiling]``:
- ``log_std_min`` is a fixed floor (mjrl's ``min_log_std``), which keeps the policy from giving up
  its exploration noise; its default, -20 (SB3's SAC clamps there too), is no floor;
- with ``anneal_log_std_iterations = N > 0`` the ceiling falls linearly from ``log_std_init`` to
  ``log_std_final`` over ``N`` iterations and stays there (explore widely early, act precisely
  late); without it there is no ceiling.
The algorithm's own step moves the log-std freely between the bounds. A floor at ``log_std_init``
with a constant ceiling there (``log_std_final = log_std_init``) holds the noise fixed while the
step still spends its trust region as it would. A run with neither bound traces nothing more.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.algos.core.config import NO_LOG_STD_FLOOR, BaseConfig
from jaxpg.algos.core.hparams import derived, divide, run_config
from jaxpg.algos.core.state import TrainState


def log_std_ceiling(config: BaseConfig, iterations_done: jax.Array, span: Any = None) -> jax.Array:
    """``[]`` float32: the log-std ceiling after ``iterations_done`` (``[]`` int) iterations,
    ``log_std_init + (log_std_final - log_std_init) * min(iterations_done / N, 1)`` for
    ``N = anneal_log_std_iterations`` (> 0). ``config``'s fields may be traced
    (``core.run_config``); ``span`` then gives ``log_std_final - log_std_init`` as the host computed
    it (``core.derived``)."""
    span = config.log_std_final - config.log_std_init if span is None else span
    done = jnp.asarray(iterations_done, jnp.float32)
    progress = jnp.clip(divide(done, config.anneal_log_std_iterations), 0.0, 1.0)
    return jnp.float32(config.log_std_init) + jnp.float32(span) * progress


def clip_log_std(ts: TrainState, iterations_done: jax.Array) -> TrainState:
    """``ts`` with its policy's ``params["log_std"]`` (``[A]``, the ``gaussian`` policy's)
    clipped to ``[log_std_min, log_std_ceiling(ts.config, iterations_done)]`` (the ceiling only
    with ``anneal_log_std_iterations`` > 0); ``ts`` itself when neither bound is set, so that such
    a run traces nothing more."""
    config = ts.config
    if not config.has_log_std_bounds:
        return ts
    run = run_config(ts)
    log_std = ts.params["log_std"]
    if config.anneal_log_std_iterations:
        span = derived(ts, "log_std_final-log_std_init")
        log_std = jnp.minimum(log_std, log_std_ceiling(run, iterations_done, span))
    if config.log_std_min > NO_LOG_STD_FLOOR:
        log_std = jnp.maximum(log_std, jnp.float32(run.log_std_min))
    return ts.replace(params={**ts.params, "log_std": log_std})
