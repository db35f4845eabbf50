"""Natural Policy Gradient (Kakade 2001) with a normalised step, as in LyceumAI and mjrl.

One iteration:
  1. sample ``num_envs x horizon`` transitions with the stochastic policy (``core.phase_sample``);
  2. advantages by GAE(gamma, lambda) (Schulman et al. 2016) from the current value function
     (``core.phase_advantages``);
  3. vanilla policy gradient ``g = grad E[A log pi(a|s)]`` (``natural_gradient.policy_gradient``);
  4. natural direction ``x = F^-1 g`` by conjugate gradient on Fisher-vector products
     (``natural_gradient.fisher_operator``) and the normalised step ``sqrt(delta / g'x) * x`` with
     ``delta = kl_delta`` (so that ``0.5 * step' F step = delta / 2``): both are
     ``natural_step``, which ``scale_by_natural_gradient`` wraps as an optax transformation that
     research code can chain;
  5. ``theta += step``, halved while its measured mean KL exceeds ``kl_bound`` (twice the
     intended ``delta / 2``; ``step_within_kl``);
  6. fit the value function to its targets by minibatch Adam (``core.phase_value_fit``);
  7. reject a non-finite update, update observation statistics (``core.finish_iteration``).

What NPG adds to the core and to the natural-gradient pieces it shares with TRPO is the
normalised step of 4 and the back-off of 5.
The iteration is written once, ``iteration(ts, run_phase)``, as the named ``PHASES`` that
``jaxpg.run.host.profiling`` times. ``make_update(advantage_fn)`` is ``update`` with another advantage
estimator in step 2, and
``update_with_kl_delta(ts, kl_delta)`` is ``update`` with a (possibly traced) ``kl_delta``, so that
one program can ``vmap`` over it.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any, ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import optax
from jax.flatten_util import ravel_pytree

from jaxpg import linalg
from jaxpg.algos import core, natural_gradient, presets
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env


@dataclasses.dataclass(frozen=True)
class Config(natural_gradient.NaturalGradientConfig):
    """NPG hyperparameters (defaults: a quick, robust setting; see ``PRESETS`` for LyceumAI's).

    ``kl_delta`` is the normalised step's delta: the step is scaled so that the quadratic model
    of its mean KL, ``0.5 * step' F step``, is ``kl_delta / 2``; its measured KL may reach
    ``kl_delta`` (``kl_bound``). ``anneal_kl_iterations`` > 0 anneals it linearly to 0 over that
    many iterations (``kl_delta_at``), as PPO anneals its learning rate. The other fields are those
    of ``NaturalGradientConfig`` (GAE, value fit, Fisher solve) and ``core.BaseConfig``.
    """

    kl_delta: float = 0.05
    anneal_kl_iterations: int = 0

    TRACED_FIELDS: ClassVar[tuple[str, ...]] = ("kl_delta", "anneal_kl_iterations")

    OLD_FIELD_NAMES: ClassVar[dict[str, str | None]] = {
        **natural_gradient.NaturalGradientConfig.OLD_FIELD_NAMES,
        "step_size": "kl_delta",
    }

    def validate(self, env: Env) -> None:
        super().validate(env)
        if not self.kl_delta > 0:
            raise ValueError(f"kl_delta must be > 0, got {self.kl_delta}")
        if self.anneal_kl_iterations < 0:
            raise ValueError(f"anneal_kl_iterations must be >= 0 (0: constant), got {self.anneal_kl_iterations}")


# Named Config overrides: a read-only view of this algorithm's rows of ``presets.TABLE``.
PRESETS = presets.by_algorithm("npg")

# Networks, the value fit's optimizer, env batch; the policy steps in closed form.
init = natural_gradient.init


def normalized_step(grad: jax.Array, direction: jax.Array, delta: jax.Array | float) -> jax.Array:
    """``[]`` step length ``sqrt(delta / g'x)`` along the natural direction ``x = F^-1 g``, both
    flat ``[num_params]``: the quadratic model ``0.5 s^2 x'Fx`` of the step's KL is ``delta / 2``."""
    return jnp.sqrt(delta / jnp.maximum(jnp.dot(grad, direction), 1e-20))


class NaturalGradientState(NamedTuple):
    """What one natural step solved (``natural_step``; the state of ``scale_by_natural_gradient``,
    in which nothing carries over from one update to the next).

    Attributes:
      direction: ``[num_params]`` the natural direction ``x = F^-1 g``, flat; the step is
        ``step_size * direction`` in the parameters' shape. For a caller that takes fractions of
        the step: NPG's KL back-off (``step_within_kl``) steps ``fraction * step_size`` along it.
      step_size: ``[]`` the normalised step length ``sqrt(kl_delta / g'x)``.
      cg_residual: ``[]`` ``||g - F x||`` as the conjugate gradient tracked it.
    """

    direction: jax.Array
    step_size: jax.Array
    cg_residual: jax.Array


def natural_step(
    grads: Any,
    fisher_vector_product: Callable[[Any], Any],
    kl_delta: jax.Array | float,
    cg_iters: int,
) -> NaturalGradientState:
    """NPG's step for the gradient ``grads`` (a pytree like the parameters): the natural direction
    ``x = F^-1 g`` (``cg_iters`` iterations of ``linalg.conjugate_gradient`` on the flattened
    vector) and the normalised step length
    ``s = sqrt(kl_delta / g'x)`` (``normalized_step``), so that the quadratic model
    ``0.5 (s x)' F (s x)`` of the step's mean KL is ``kl_delta / 2`` (Kakade 2001; the step of
    LyceumAI and mjrl). ``fisher_vector_product(v) -> (F + damping I) v`` maps pytrees like
    ``grads`` (``natural_gradient.fisher_operator``)."""
    flat_grad, _ = ravel_pytree(grads)
    cg = linalg.conjugate_gradient(natural_gradient.flat_operator(fisher_vector_product, grads), flat_grad, cg_iters)
    return NaturalGradientState(cg.x, normalized_step(flat_grad, cg.x, kl_delta), cg.residual_norm)


def scale_by_natural_gradient(kl_delta: jax.Array | float, cg_iters: int) -> optax.GradientTransformationExtraArgs:
    """``natural_step`` as an optax transformation, for research code that chains it: a gradient
    ``g`` in, ``s x`` out (``NaturalGradientState``'s ``step_size * direction``, shaped like the
    parameters). NPG's own ``update`` calls ``natural_step`` directly, since its KL back-off takes
    fractions of the step.

    ``update(grads, state, params=None, *, fisher_vector_product)``: ``grads`` and the returned
    updates are pytrees shaped like the parameters; ``fisher_vector_product(v) -> (F + damping I) v``
    maps such pytrees at the current parameters (``linalg.make_fisher_vector_product``, which
    takes the damping, or ``natural_gradient.fisher_operator``). It is an extra argument of
    ``update`` (``optax.GradientTransformationExtraArgs``) because ``F`` moves with the parameters
    and the batch; ``optax.chain`` hands it through.

    The updates point along ``+g``'s natural direction: for the gradient of an objective to
    maximise (NPG's surrogate) apply them as they are, for a loss chain ``optax.scale(-1.0)``
    after it. ``kl_delta`` may be traced (``update_with_kl_delta``).
    """

    def init(params: Any) -> NaturalGradientState:
        flat_params, _ = ravel_pytree(params)
        return NaturalGradientState(jnp.zeros_like(flat_params), jnp.zeros(()), jnp.zeros(()))

    def update(
        grads: Any,
        state: NaturalGradientState,
        params: Any = None,
        *,
        fisher_vector_product: Callable[[Any], Any],
        **extra_args: Any,
    ) -> tuple[Any, NaturalGradientState]:
        del state, params, extra_args
        solve = natural_step(grads, fisher_vector_product, kl_delta, cg_iters)
        _, unravel = ravel_pytree(grads)
        return unravel(solve.step_size * solve.direction), solve

    return optax.GradientTransformationExtraArgs(init, update)


def kl_delta_at(config: Config, iteration: jax.Array) -> jax.Array | float:
    """The normalised step's delta at ``iteration`` (``[]``, iterations completed):
    ``config.kl_delta``, or with ``anneal_kl_iterations = N > 0`` the linear decay
    ``kl_delta * (1 - iteration / N)``, which is 0 from iteration ``N`` on (no step). ``config``'s
    fields may be traced (``core.run_config``; a traced ``N`` always anneals)."""
    if isinstance(config.anneal_kl_iterations, int) and not config.anneal_kl_iterations:
        return config.kl_delta
    remaining = 1.0 - core.divide(iteration.astype(jnp.float32), config.anneal_kl_iterations)
    return config.kl_delta * jnp.clip(remaining, 0.0, 1.0)


BACKTRACKS = 6  # halvings of the natural step tried when it overshoots its KL bound


def kl_bound(config: Config, kl_delta: jax.Array | float | None = None, check: bool | None = None) -> jax.Array | float:
    """The mean KL an NPG step may reach: twice the ``kl_delta / 2`` that the normalised step
    aims at in the Fisher metric, and never more than ``max_update_kl`` (when that is set).

    ``kl_delta`` (e.g. a traced array, see ``update_with_kl_delta``) stands in for
    ``config.kl_delta``; the bound is then an array. ``check`` says whether ``max_update_kl`` is
    set, for a ``config`` whose fields are traced (``core.run_config``)."""
    check = config.max_update_kl > 0 if check is None else check
    if kl_delta is None:
        return min(config.kl_delta, config.max_update_kl) if check else config.kl_delta
    return jnp.minimum(kl_delta, config.max_update_kl) if check else jnp.asarray(kl_delta)


def step_within_kl(
    ts: TrainState, batch: core.Batch, direction: jax.Array, step: jax.Array, bound: jax.Array | float
) -> tuple[Any, jax.Array, jax.Array]:
    """The longest of ``step, step/2, ... step/2^(BACKTRACKS-1)`` along ``direction`` (flat
    ``[num_params]``) whose mean KL stays within ``bound`` (``kl_bound``); all candidates are
    evaluated at once.

    Returns ``(new_params, kl [], fraction [])``: ``fraction`` is the share of ``step`` taken, 0
    (parameters unchanged, KL 0) when even the smallest candidate overshoots. The quadratic model
    behind the normalised step is usually accurate, so the full step (``fraction`` 1) is the rule.
    """
    flat_params, unravel = ravel_pytree(ts.params)
    fractions = 0.5 ** jnp.arange(BACKTRACKS, dtype=jnp.float32)
    kls = jax.vmap(lambda f: core.mean_kl(ts, ts.params, unravel(flat_params + f * step * direction), batch))(fractions)
    fits = kls <= bound
    first = jnp.argmax(fits)
    fraction = jnp.where(jnp.any(fits), fractions[first], 0.0)
    return unravel(flat_params + fraction * step * direction), jnp.where(jnp.any(fits), kls[first], 0.0), fraction


PHASES = ("sampling", "advantages", "gradient", "natural_step", "kl_backoff", "value_fit", "finish")
"""The phases of ``iteration``, in order (``core.run_inline``; ``jaxpg.run.host.profiling`` times them)."""


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One NPG iteration (module docstring); pure, jittable, vmappable over seeds."""
    return iteration(ts)


def iteration(ts: TrainState, run_phase: core.PhaseRunner = core.run_inline) -> tuple[TrainState, dict[str, jax.Array]]:
    """One NPG iteration with GAE, each of its ``PHASES`` run by ``run_phase``: ``update`` runs
    them inline, a profiler times them one by one."""
    return update_using(ts, core.gae_advantages, run_phase=run_phase)


def update_with_kl_delta(ts: TrainState, kl_delta: jax.Array | float) -> tuple[TrainState, dict[str, jax.Array]]:
    """``update`` with the normalised step's ``kl_delta`` in place of ``config.kl_delta``.

    ``Config`` is static in ``TrainState``, so a sweep over ``config.kl_delta`` compiles one
    program per value; ``kl_delta`` here may be traced, so that one program ``vmap``s over its
    values (and seeds), e.g. ``jax.vmap(npg.update_with_kl_delta)(states, jnp.array([0.01, 0.1]))``.
    The KL bound of the backtracking follows it (``kl_bound(config, kl_delta)``); everything else
    is ``update``'s, and ``update_with_kl_delta(ts, ts.config.kl_delta)`` gives ``update(ts)``.
    """
    return update_using(ts, core.gae_advantages, kl_delta)


def phase_natural_step(
    ts: TrainState, batch: core.Batch, grads: Any, kl_delta: jax.Array | float
) -> NaturalGradientState:
    """``natural_step`` with the Fisher matrix of ``fisher_subsample``'s states at ``ts.params``."""
    fvp = natural_gradient.fisher_operator(ts, *natural_gradient.fisher_subsample(ts, batch))
    return natural_step(grads, fvp, kl_delta, ts.config.cg_iters)


def phase_kl_backoff(
    ts: TrainState, batch: core.Batch, solve: NaturalGradientState, bound: jax.Array | float
) -> tuple[Any, jax.Array, jax.Array, jax.Array]:
    """``step_within_kl`` along ``solve``'s step, and the entropy of the policy it left:
    ``(new_params, kl, fraction, entropy)``."""
    new_params, kl, fraction = step_within_kl(ts, batch, solve.direction, solve.step_size, bound)
    return new_params, kl, fraction, core.mean_entropy(ts, ts.params, batch)


def phase_finish(
    old: TrainState, ts: TrainState, traj: Any, kl: jax.Array, fraction: jax.Array, metrics: dict[str, jax.Array]
) -> tuple[TrainState, dict[str, jax.Array]]:
    """``core.finish_iteration`` of an NPG step that took ``fraction`` of the natural step."""
    loss = metrics["value_loss"] + kl
    return core.finish_iteration(old, ts, traj, loss=loss, kl=kl, metrics=metrics, step_accepted=fraction > 0)


def update_using(
    ts: TrainState,
    advantage_fn: core.AdvantageFn,
    kl_delta: jax.Array | float | None = None,
    run_phase: core.PhaseRunner = core.run_inline,
) -> tuple[TrainState, dict[str, jax.Array]]:
    """One NPG iteration whose advantages and value targets come from ``advantage_fn``
    (``update`` is ``update_using(ts, core.gae_advantages)``; ``make_update`` binds another
    estimator), stepping with ``kl_delta`` when given (``update_with_kl_delta``), else with
    ``kl_delta_at(config, ts.iteration)``; each of ``PHASES`` run by ``run_phase``."""
    old = ts
    ts, traj, key = run_phase("sampling", core.phase_sample, ts)
    value_key, _ = jax.random.split(key)
    advantages = functools.partial(core.phase_advantages, advantage_fn=advantage_fn)
    batch = run_phase("advantages", advantages, ts, traj)
    grads = run_phase("gradient", natural_gradient.policy_gradient, ts, batch)
    run = core.run_config(ts)
    if kl_delta is None and ts.config.anneal_kl_iterations:
        kl_delta = kl_delta_at(run, old.iteration)
    elif kl_delta is None and core.is_traced(ts):
        kl_delta = run.kl_delta
    delta = ts.config.kl_delta if kl_delta is None else kl_delta
    solve = run_phase("natural_step", phase_natural_step, ts, batch, grads, delta)
    bound = kl_bound(run, kl_delta, ts.config.max_update_kl > 0)
    new_params, kl, fraction, entropy = run_phase("kl_backoff", phase_kl_backoff, ts, batch, solve, bound)
    ts, value_loss = run_phase("value_fit", core.phase_value_fit, ts.replace(params=new_params), batch, value_key)
    metrics = {
        "entropy": entropy,
        "step_length": fraction * solve.step_size,
        "step_fraction": fraction,
        "cg_residual": solve.cg_residual,
        "grad_norm": jnp.linalg.norm(ravel_pytree(grads)[0]),
        "value_loss": value_loss,
    }
    return run_phase("finish", phase_finish, old, ts, traj, kl, fraction, metrics)


@functools.cache
def make_update(
    advantage_fn: core.AdvantageFn = core.gae_advantages,
) -> Callable[[TrainState], tuple[TrainState, dict]]:
    """NPG's ``update`` with the advantage estimator ``advantage_fn`` in place of GAE: a research
    hook that keeps everything else of the iteration (sampling, advantage normalisation, the
    env-major ``Batch``, natural gradient, KL-bounded step, value fit, guards and metrics).

    ``advantage_fn(ts, traj, values, next_values) -> (advantages, value_targets)`` works on
    ``[T, B]`` arrays (see ``core.gae_advantages``); ``core.phase_advantages`` flattens what it
    returns, so a custom estimator never flattens by hand. ``make_update(core.gae_advantages)`` is
    ``update``; the same ``advantage_fn`` gives the same function (and so the same compiled
    program in ``train``).
    """
    if advantage_fn is core.gae_advantages:
        return update

    def update_with(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
        return update_using(ts, advantage_fn)

    name = getattr(advantage_fn, "__name__", type(advantage_fn).__name__)
    update_with.__name__ = update_with.__qualname__ = f"update[{name}]"
    update_with.__doc__ = f"One NPG iteration with advantages from ``{name}`` (``npg.make_update``)."
    return update_with
