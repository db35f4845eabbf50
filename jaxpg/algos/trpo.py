"""Trust Region Policy Optimization (Schulman et al. 2015).

The natural direction ``x = F^-1 g`` (``jaxpg.algos.natural_gradient``, as NPG), scaled to the
edge of the trust region ``0.5 x'Fx s^2 = max_kl`` and then shrunk by a backtracking line search:
the first of ``step, step*b, step*b^2 ...`` whose surrogate improves and whose mean KL stays within
``max_kl`` is taken; if none qualifies the policy is left unchanged. All candidates are evaluated
at once (``vmap``), which suits the accelerator better than a sequential loop.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
from jax.flatten_util import ravel_pytree

from jaxpg.algos import core, natural_gradient, presets
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env


@dataclasses.dataclass(frozen=True)
class Config(natural_gradient.NaturalGradientConfig):
    """TRPO: ``max_kl`` is the trust region delta; ``backtracks`` candidates shrinking by
    ``backtrack_ratio``; a candidate must reach ``accept_ratio`` of its first-order predicted
    improvement. The other fields are those of ``NaturalGradientConfig`` and ``core.BaseConfig``."""

    max_kl: float = 0.01
    backtracks: int = 10
    backtrack_ratio: float = 0.8
    accept_ratio: float = 0.1

    TRACED_FIELDS: ClassVar[tuple[str, ...]] = ("max_kl", "backtrack_ratio", "accept_ratio")

    # Configs saved before TRPO stopped inheriting NPG's step size (which it never used).
    OLD_FIELD_NAMES: ClassVar[dict[str, str | None]] = {
        **natural_gradient.NaturalGradientConfig.OLD_FIELD_NAMES,
        "step_size": None,
    }

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.max_kl <= 0 or self.backtracks < 1 or not 0 < self.backtrack_ratio < 1:
            raise ValueError("max_kl must be > 0, backtracks >= 1 and 0 < backtrack_ratio < 1")


# Named Config overrides: a read-only view of this algorithm's rows of ``presets.TABLE``.
PRESETS = presets.by_algorithm("trpo")

# Networks, the value fit's optimizer, env batch; the policy steps in closed form.
init = natural_gradient.init


def line_search(
    ts: TrainState, batch: core.Batch, grad: jax.Array, direction: jax.Array
) -> tuple[Any, dict[str, jax.Array]]:
    """Backtracking line search along ``direction`` (flat ``[num_params]``) from the full step to
    the trust region's edge; returns the new params and ``[]`` diagnostics: ``step_length`` (0
    when rejected), ``kl``, ``surrogate_improvement``, ``line_search_accepted`` and
    ``line_search_backtracks``."""
    config = core.run_config(ts)
    flat_params, unravel = ravel_pytree(ts.params)
    curvature = jnp.dot(direction, natural_gradient.fisher_vector_product(ts, batch.obs, batch.weights)(direction))
    full_step = jnp.sqrt(core.derived(ts, "2*max_kl") / jnp.maximum(curvature, 1e-20))
    fractions = config.backtrack_ratio ** jnp.arange(ts.config.backtracks, dtype=jnp.float32)
    baseline = natural_gradient.surrogate(ts, ts.params, batch)

    def evaluate(fraction: jax.Array) -> tuple[jax.Array, jax.Array]:
        params = unravel(flat_params + fraction * full_step * direction)
        return natural_gradient.surrogate(ts, params, batch) - baseline, core.mean_kl(ts, ts.params, params, batch)

    improvement, kl = jax.vmap(evaluate)(fractions)
    expected = fractions * full_step * jnp.dot(grad, direction)
    ok = (kl <= config.max_kl) & (improvement > 0) & (improvement >= config.accept_ratio * expected)
    first = jnp.argmax(ok)
    accepted = jnp.any(ok)
    step = jnp.where(accepted, fractions[first] * full_step, 0.0)
    new_params = unravel(flat_params + step * direction)
    return new_params, {
        "step_length": step,
        "kl": jnp.where(accepted, kl[first], 0.0),
        "surrogate_improvement": jnp.where(accepted, improvement[first], 0.0),
        "line_search_accepted": accepted.astype(jnp.float32),
        "line_search_backtracks": jnp.where(accepted, first, ts.config.backtracks).astype(jnp.float32),
    }


PHASES = ("sampling", "advantages", "gradient", "natural_direction", "line_search", "value_fit", "finish")
"""The phases of ``iteration``, in order (``core.run_inline``; ``jaxpg.run.host.profiling`` times them)."""


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One TRPO iteration: sample, GAE, the natural direction, the line search along it, the value
    fit, the guard; pure, jittable, vmappable over seeds."""
    return iteration(ts)


def phase_line_search(
    ts: TrainState, batch: core.Batch, grad: jax.Array, direction: jax.Array
) -> tuple[Any, dict[str, jax.Array], jax.Array]:
    """``line_search`` along ``direction`` and the entropy of the policy it started from:
    ``(new_params, search metrics with "kl", entropy)``."""
    new_params, search = line_search(ts, batch, grad, direction)
    return new_params, search, core.mean_entropy(ts, ts.params, batch)


def phase_finish(
    old: TrainState, ts: TrainState, traj: Any, kl: jax.Array, metrics: dict[str, jax.Array]
) -> tuple[TrainState, dict[str, jax.Array]]:
    """``core.finish_iteration`` of a TRPO step."""
    return core.finish_iteration(old, ts, traj, loss=metrics["value_loss"] + kl, kl=kl, metrics=metrics)


def iteration(ts: TrainState, run_phase: core.PhaseRunner = core.run_inline) -> tuple[TrainState, dict[str, jax.Array]]:
    """One TRPO iteration, each of its ``PHASES`` run by ``run_phase`` (``update``: inline)."""
    old = ts
    ts, traj, key = run_phase("sampling", core.phase_sample, ts)
    value_key, _ = jax.random.split(key)
    batch = run_phase("advantages", core.phase_advantages, ts, traj)
    grad = run_phase("gradient", natural_gradient.phase_gradient, ts, batch)
    cg = run_phase("natural_direction", natural_gradient.phase_natural_gradient, ts, batch, grad)
    new_params, search, entropy = run_phase("line_search", phase_line_search, ts, batch, grad, cg.x)
    kl = search.pop("kl")
    ts, value_loss = run_phase("value_fit", core.phase_value_fit, ts.replace(params=new_params), batch, value_key)
    metrics = {
        **search,
        "entropy": entropy,
        "cg_residual": cg.residual_norm,
        "grad_norm": jnp.linalg.norm(grad),
        "value_loss": value_loss,
    }
    return run_phase("finish", phase_finish, old, ts, traj, kl, metrics)
