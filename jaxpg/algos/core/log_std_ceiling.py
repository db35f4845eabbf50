"""A falling ceiling on a Gaussian policy's global log-std: explore widely early, act precisely late.

With ``anneal_log_std_iterations = N > 0`` the policy's learned log-std vector is capped, at the
end of every iteration (``core.finish_iteration``), by a ceiling that falls linearly from
``log_std_init`` to ``log_std_final`` over ``N`` iterations and stays there. The algorithm's own
step still moves the log-std freely below the ceiling; only a policy that keeps its noise above
the schedule is pulled down. OpenAI Baselines' PPO anneals a fixed log-std linearly for the same
reason: the wide noise that keeps early learning out of poor local optima is the noise a
deterministic (mean) policy never sees.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxpg.algos.core.config import BaseConfig
from jaxpg.algos.core.state import TrainState


def log_std_ceiling(config: BaseConfig, iterations_done: jax.Array) -> jax.Array:
    """``[]`` float32: the log-std ceiling after ``iterations_done`` (``[]`` int) iterations,
    ``log_std_init + (log_std_final - log_std_init) * min(iterations_done / N, 1)`` for
    ``N = anneal_log_std_iterations`` (> 0)."""
    progress = jnp.clip(jnp.asarray(iterations_done, jnp.float32) / config.anneal_log_std_iterations, 0.0, 1.0)
    return jnp.float32(config.log_std_init) + jnp.float32(config.log_std_final - config.log_std_init) * progress


def cap_log_std(ts: TrainState, iterations_done: jax.Array) -> TrainState:
    """``ts`` with its policy's ``params["log_std"]`` (``[A]``, the ``gaussian`` policy's)
    capped at ``log_std_ceiling(ts.config, iterations_done)``; ``ts`` itself when annealing is off
    (``anneal_log_std_iterations == 0``), so that such a run traces nothing more."""
    if not ts.config.anneal_log_std_iterations:
        return ts
    ceiling = log_std_ceiling(ts.config, iterations_done)
    params = {**ts.params, "log_std": jnp.minimum(ts.params["log_std"], ceiling)}
    return ts.replace(params=params)
