"""Trust Region Policy Optimization (Schulman et al. 2015).

The NPG direction ``x = F^-1 g`` (same phases as ``jaxpg.algos.npg``), scaled to the edge of the
trust region ``0.5 x'Fx s^2 = delta`` and then shrunk by a backtracking line search: the first of
``step, step*b, step*b^2 ...`` whose surrogate improves and whose mean KL stays within ``max_kl``
is taken; if none qualifies the policy is left unchanged. All candidates are evaluated at once
(``vmap``), which suits the accelerator better than a sequential loop.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
from jax.flatten_util import ravel_pytree

from jaxpg import linalg
from jaxpg.algos import common, npg
from jaxpg.algos.common import TrainState
from jaxpg.envs import Env


@dataclasses.dataclass(frozen=True)
class Config(npg.Config):
    """TRPO: ``max_kl`` is the trust region delta; ``backtracks`` candidates shrinking by
    ``backtrack_ratio``; a candidate must reach ``accept_ratio`` of its first-order predicted
    improvement."""

    max_kl: float = 0.01
    backtracks: int = 10
    backtrack_ratio: float = 0.8
    accept_ratio: float = 0.1

    # NPG's normalised step size: TRPO's step comes from max_kl (no command-line flag).
    UNUSED_FIELDS: ClassVar[tuple[str, ...]] = ("step_size",)

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.step_size != npg.Config.step_size:
            raise ValueError("TRPO does not use step_size (NPG's normalised step); its trust region is max_kl")
        if self.max_kl <= 0 or self.backtracks < 1 or not 0 < self.backtrack_ratio < 1:
            raise ValueError("max_kl must be > 0, backtracks >= 1 and 0 < backtrack_ratio < 1")


PRESETS: dict[str, dict[str, Any]] = {"lyceum": {**npg.PRESETS["lyceum"], "max_kl": 0.05}}

init = npg.init


def line_search(
    ts: TrainState, batch: npg.Batch, grad: jax.Array, direction: jax.Array
) -> tuple[Any, dict[str, jax.Array]]:
    """Backtracking line search along ``direction`` (flat); returns new params and diagnostics."""
    config = ts.config
    flat_params, unravel = ravel_pytree(ts.params)
    fvp = linalg.make_fisher_vector_product(
        ts.policy, ts.params, batch.obs, weights=batch.weights, damping=config.cg_damping, mode=config.fvp
    )
    curvature = jnp.dot(direction, ravel_pytree(fvp(unravel(direction)))[0])
    full_step = jnp.sqrt(2.0 * config.max_kl / jnp.maximum(curvature, 1e-20))
    fractions = config.backtrack_ratio ** jnp.arange(config.backtracks, dtype=jnp.float32)
    baseline = npg.surrogate(ts, ts.params, batch)

    def evaluate(fraction: jax.Array) -> tuple[jax.Array, jax.Array]:
        params = unravel(flat_params + fraction * full_step * direction)
        return npg.surrogate(ts, params, batch) - baseline, npg.mean_kl(ts, ts.params, params, batch)

    improvement, kl = jax.vmap(evaluate)(fractions)
    expected = fractions * full_step * jnp.dot(grad, direction)
    ok = (kl <= config.max_kl) & (improvement > 0) & (improvement >= config.accept_ratio * expected)
    first = jnp.argmax(ok)
    accepted = jnp.any(ok)
    step = jnp.where(accepted, fractions[first] * full_step, 0.0)
    new_params = unravel(flat_params + step * direction)
    return new_params, {
        "step_size": step,
        "kl": jnp.where(accepted, kl[first], 0.0),
        "surrogate_improvement": jnp.where(accepted, improvement[first], 0.0),
        "line_search_accepted": accepted.astype(jnp.float32),
        "line_search_backtracks": jnp.where(accepted, first, config.backtracks).astype(jnp.float32),
    }


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One TRPO iteration: NPG phases, then the line search instead of the fixed normalised step."""
    old = ts
    ts, traj, key = npg.phase_sample(ts)
    value_key, _ = jax.random.split(key)
    batch = npg.phase_advantages(ts, traj)
    grad = npg.phase_gradient(ts, batch)
    cg = npg.phase_natural_gradient(ts, batch, grad)
    new_params, search = line_search(ts, batch, grad, cg.x)
    entropy = common.weighted_mean(ts.policy.entropy(ts.params, batch.obs), batch.weights)
    ts = ts.replace(params=new_params)
    ts, value_loss = npg.phase_value_fit(ts, batch, value_key)
    metrics = {
        **search,
        "entropy": entropy,
        "cg_residual": cg.residual_norm,
        "grad_norm": jnp.linalg.norm(grad),
        "value_loss": value_loss,
    }
    return npg.finish_iteration(old, ts, traj, value_loss + search["kl"], metrics)
