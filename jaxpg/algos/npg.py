"""Natural Policy Gradient (Kakade 2001) with a normalised step, as in LyceumAI and mjrl.

One iteration:
  1. sample ``num_envs x horizon`` transitions with the stochastic policy;
  2. advantages by GAE(gamma, lambda) (Schulman et al. 2016) from the current value function;
  3. vanilla policy gradient ``g = grad E[A log pi(a|s)]``;
  4. natural direction ``x = F^-1 g`` by conjugate gradient on Fisher-vector products;
  5. normalised step ``theta += sqrt(delta / g'x) * x`` (so that 0.5 * step' F step = delta / 2),
     halved while its measured mean KL exceeds ``kl_bound`` (twice the intended ``delta / 2``);
  6. fit the value function to its targets by minibatch Adam.

Each phase is a named function of its own, so that ``update`` reads as the list above, TRPO
reuses the phases, and ``profile_phases`` can time them as separate jitted calls.
``make_update(advantage_fn)`` is ``update`` with another advantage estimator in step 2, and
``update_with_step_size(ts, step_size)`` is ``update`` with a (possibly traced) step size, so that
one program can ``vmap`` over step sizes.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import optax
from flax import struct
from jax.flatten_util import ravel_pytree

from jaxpg import linalg, returns
from jaxpg import value as value_lib
from jaxpg.algos import common
from jaxpg.algos.common import TrainState
from jaxpg.envs import Env
from jaxpg.rollout import Trajectory, flatten_samples


@dataclasses.dataclass(frozen=True)
class Config(common.BaseConfig):
    """NPG hyperparameters (defaults: a quick, robust setting; see ``PRESETS`` for LyceumAI's).

    ``step_size`` is the normalised step delta; ``fvp`` selects the Fisher-vector product
    (``"gauss_newton"``: J'MJ with the distribution's analytic Fisher metric, or
    ``"kl_hessian"``: Hessian of the mean KL); ``value_target`` is ``"gae"`` (lambda-returns) or
    ``"returns"`` (discounted returns, as LyceumAI fits). ``normalize_value_targets`` fits the value
    network to targets standardised by their running statistics (``TrainState.value_stats``),
    rescaling its output layer whenever they move so that its predictions are kept (PopArt's
    "preserve outputs"); the ``value_loss`` metric is then in standardised units.
    ``value_minibatches`` > 0 splits each value epoch into that many minibatches instead of
    minibatches of ``value_batch_size`` samples, so that the value fit takes the same number of
    steps whatever ``num_envs`` and ``horizon`` are. ``value_epoch_samples`` > 0 caps the samples
    one value epoch visits (minibatches drawn with replacement from the batch when it holds more),
    so that the value fit costs the same at any larger batch. ``fisher_samples`` > 0 builds the
    Fisher-vector products of the conjugate gradient from that many samples of the batch, drawn
    afresh each iteration (Schulman et al. 2015 used 10 % of the batch), so that the solve stops
    growing with the batch; the gradient and the KL check still use every sample.
    ``sample_budget`` > 0 caps the number of valid samples in episodic sampling, filling env by
    env as LyceumAI's sampler does.
    """

    @property
    def value_minibatch_size(self) -> int:
        """Samples per value-fit minibatch (``value_minibatches`` wins over ``value_batch_size``)."""
        if self.value_minibatches > 0:
            return max(1, self.value_samples_per_epoch // self.value_minibatches)
        return self.value_batch_size

    @property
    def value_samples_per_epoch(self) -> int:
        """Samples one value epoch visits: the iteration's, or ``value_epoch_samples`` if fewer."""
        if self.value_epoch_samples > 0:
            return min(self.value_epoch_samples, self.samples_per_iteration)
        return self.samples_per_iteration

    gamma: float = 0.995
    gae_lambda: float = 0.97
    step_size: float = 0.05
    cg_iters: int = 10
    cg_damping: float = 1e-4
    fvp: str = "gauss_newton"
    normalize_advantages: bool = True
    value_lr: float = 1e-3
    value_epochs: int = 3
    value_batch_size: int = 64
    value_minibatches: int = 0
    value_epoch_samples: int = 0
    fisher_samples: int = 0
    value_target: str = "gae"
    normalize_value_targets: bool = False
    sample_budget: int = 0

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.value_minibatches < 0 or self.value_minibatches > self.samples_per_iteration:
            raise ValueError(
                f"value_minibatches must be in [0, {self.samples_per_iteration}] (the samples of an iteration), "
                f"got {self.value_minibatches}"
            )
        if self.value_minibatches == 0 and self.value_batch_size > self.samples_per_iteration:
            raise ValueError(
                f"value_batch_size {self.value_batch_size} exceeds the {self.samples_per_iteration} samples "
                f"of an iteration (num_envs {self.num_envs} x horizon {self.horizon})"
            )
        if self.fvp not in ("gauss_newton", "kl_hessian"):
            raise ValueError(f"fvp must be 'gauss_newton' or 'kl_hessian', got {self.fvp!r}")
        if self.value_target not in ("gae", "returns"):
            raise ValueError(f"value_target must be 'gae' or 'returns', got {self.value_target!r}")
        if not self.step_size > 0 or self.cg_iters < 1:
            raise ValueError(f"step_size must be > 0 and cg_iters >= 1, got {self.step_size}, {self.cg_iters}")
        if not 0 <= self.gae_lambda <= 1:
            raise ValueError(f"gae_lambda must be in [0, 1], got {self.gae_lambda}")
        if not self.cg_damping >= 0 or not self.value_lr > 0:
            raise ValueError(f"cg_damping must be >= 0 and value_lr > 0, got {self.cg_damping}, {self.value_lr}")
        if self.value_epoch_samples < 0 or 0 < self.value_epoch_samples < self.value_minibatches:
            raise ValueError(
                f"value_epoch_samples must be 0 (all) or at least value_minibatches ({self.value_minibatches}), "
                f"got {self.value_epoch_samples}"
            )
        if self.fisher_samples < 0:
            raise ValueError(f"fisher_samples must be >= 0 (0: all), got {self.fisher_samples}")
        if self.value_epochs < 1 or self.value_batch_size < 1 or self.sample_budget < 0:
            raise ValueError(
                "value_epochs and value_batch_size must be >= 1 and sample_budget >= 0, got "
                f"{self.value_epochs}, {self.value_batch_size}, {self.sample_budget}"
            )


PRESETS: dict[str, dict[str, Any]] = {
    # inverted_pendulum on a 2-core CPU: 4096 samples an iteration. Normalised step 0.03: with
    # the former 0.1 (BENCHMARKS.md, section H, was measured with it) the mean policies solved the
    # task in 10-40 iterations but kept collapsing to returns below 100 afterwards (seeds 0-3: never
    # three evaluations in a row >= 950 for all four within 100 iterations; 0.05 collapsed less).
    # With 0.03 seeds 0-3 evaluated at 1000 at every evaluation from iteration 25 to 60
    # (tests/test_learning.py); one of them relapsed after 65.
    "pendulum_cpu": dict(
        num_envs=32,
        horizon=128,
        gamma=0.99,
        step_size=0.03,
        policy_hidden=(32, 32),
        value_hidden=(64, 64),
        value_batch_size=512,
    ),
    # Hopper from the command line (the defaults of experiments/hopper.py): 256 envs x 64 steps,
    # 120 iterations (1.97 M env steps). Chosen by benchmarks/hopper_sweep.py on one H100 over
    # eight seeds (BENCHMARKS.md): a normalised step of 0.07, 10 value epochs per iteration on
    # standardised value targets (16 minibatches an epoch: 1024 samples at 256 x 64, and the same
    # number of steps at any --num-envs) and an initial log-std of 0 (std 1) took all eight seeds' mean
    # policies past 3000 by 1.05 M steps and past 3290 by 1.97 M. Without the last two, four of
    # eight seeds ended below 3000 (238-1713): in the "dive forward once" local optimum (return
    # ~235), standing (~1000), or still on the way.
    # A value epoch visits at most 16384 samples (all of them at 256 x 64), so that above 256
    # envs the value fit stops growing with the batch: at 65536 envs it took 16% of an iteration
    # (train/raw 0.67 -> 0.78 with the cap; at 4096 envs the mean policy still reached 3506 in
    # 120 iterations, 3451 without it).
    # Likewise the conjugate gradient's Fisher-vector products use 16384 samples of the batch
    # (12% of an iteration at 65536 envs otherwise): with both caps train/raw is 0.91 at 16384
    # envs and 0.89 at 65536, and the mean policy reached 3349 at 4096 envs (120 iterations)
    # and 3319 at 16384 (60 iterations).
    # The mean policy is evaluated after the last iteration (and every 120): one evaluation
    # (1000 sequential steps) is ~1.3 s on an H100, 3% of a warm run; its program is compiled
    # on a background thread while training runs.
    "hopper": dict(
        num_envs=256,
        horizon=64,
        step_size=0.07,
        normalize_observations=True,
        log_std_init=0.0,
        value_hidden=(128, 128),
        value_epochs=10,
        value_minibatches=16,
        value_epoch_samples=16384,
        fisher_samples=16384,
        normalize_value_targets=True,
        eval_envs=16,
        eval_every=120,
    ),
    # Hopper on one GPU (BENCHMARKS.md: mean-policy return 3000 in a median 46 s on an H200).
    "hopper_gpu": dict(
        num_envs=8192,
        horizon=64,
        normalize_observations=True,
        value_batch_size=32768,
        value_epochs=2,
        step_size=0.1,
        policy_hidden=(64, 64),
        value_hidden=(256, 256),
        eval_envs=32,
        eval_every=10,
    ),
    # LyceumAI's NaturalPolicyGradient on HopperV2 (Summers et al., L4DC 2020).
    "lyceum": dict(
        sampling="episodic",
        num_envs=11,
        horizon=1000,
        sample_budget=10240,
        gamma=0.995,
        gae_lambda=0.97,
        step_size=0.05,
        policy="gaussian",
        policy_hidden=(32, 32),
        policy_activation="tanh",
        policy_init="glorot_uniform",
        log_std_init=0.0,
        value_hidden=(128, 128),
        value_activation="relu",
        value_lr=1e-3,
        value_epochs=3,
        value_batch_size=64,
        value_target="returns",
        normalize_observations=False,
    ),
}


@struct.dataclass
class Batch:
    """One iteration's training batch, flattened to ``[N = horizon * num_envs]``.

    ``obs`` is normalised with the statistics the batch was sampled with; ``weights`` is the
    validity mask (zero for padding steps of episodic sampling).
    """

    obs: jax.Array
    actions: jax.Array
    log_probs: jax.Array
    advantages: jax.Array
    value_targets: jax.Array
    weights: jax.Array


def init(key: jax.Array, env: Env, config: Config) -> TrainState:
    """A fresh ``TrainState``: networks, value optimizer, env batch."""
    return common.init_common(key, env, config, value_opt_init=value_optimizer(config).init)


def value_optimizer(config: Config) -> optax.GradientTransformation:
    return optax.adam(config.value_lr)


def apply_sample_budget(traj: Trajectory, budget: int) -> Trajectory:
    """Keep the first ``budget`` valid samples, counting env by env (``[T, B]`` masks)."""
    if budget <= 0:
        return traj
    env_major = traj.valid.T.reshape(-1)
    keep = (jnp.cumsum(env_major) <= budget).reshape(traj.valid.T.shape).T
    return traj.replace(valid=traj.valid * keep)


def phase_sample(ts: TrainState) -> tuple[TrainState, Trajectory, jax.Array]:
    """Sample a batch; returns the state with advanced key/env state, the trajectory and a key
    for the later phases."""
    key, sample_key, rest_key = jax.random.split(ts.key, 3)
    env_state, traj = common.sample(ts, sample_key)
    traj = apply_sample_budget(traj, ts.config.sample_budget)
    return ts.replace(key=key, env_state=env_state), traj, rest_key


AdvantageFn = Callable[[TrainState, Trajectory, jax.Array, jax.Array], tuple[jax.Array, jax.Array]]
"""``(ts, traj, values, next_values) -> (advantages, value_targets)``, every array ``[T, B]``."""


def gae_advantages(
    ts: TrainState, traj: Trajectory, values: jax.Array, next_values: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """NPG's advantage estimator (an ``AdvantageFn``): GAE(gamma, gae_lambda) advantages and the
    value targets ``config.value_target`` selects, all ``[T, B]``.

    ``values`` and ``next_values`` are ``V(obs)`` and ``V(next_obs)`` of ``traj`` in return units
    (``value_predictions``), computed once by ``phase_advantages``.
    """
    config = ts.config
    advantages, targets = returns.gae(
        traj.rewards, values, next_values, traj.terminated, traj.truncated, config.gamma, config.gae_lambda
    )
    if config.value_target == "returns":
        targets = returns.discounted_returns(
            traj.rewards, traj.terminated, traj.truncated, config.gamma, next_values=next_values
        )
    return advantages, targets


def phase_advantages(ts: TrainState, traj: Trajectory, advantage_fn: AdvantageFn = gae_advantages) -> Batch:
    """Advantages and value targets from the current value function (GAE unless ``advantage_fn``
    says otherwise), normalised advantages when ``config.normalize_advantages``, all flattened to a
    ``Batch`` by ``flatten_samples`` (env-major rows, as every algorithm lays out its batch)."""
    config = ts.config
    obs = ts.obs_stats.normalize(traj.obs)
    next_obs = ts.obs_stats.normalize(traj.next_obs)
    values = value_predictions(ts, obs)
    next_values = value_predictions(ts, next_obs)
    advantages, targets = advantage_fn(ts, traj, values, next_values)
    if config.normalize_advantages:
        advantages = returns.normalize(advantages, mask=traj.valid)

    flat = flatten_samples
    return Batch(
        obs=flat(obs),
        actions=flat(traj.actions),
        log_probs=flat(traj.log_probs),
        advantages=flat(advantages),
        value_targets=flat(targets),
        weights=flat(traj.valid),
    )


def surrogate(ts: TrainState, params: Any, batch: Batch) -> jax.Array:
    """Importance-weighted surrogate ``E[pi(a|s)/pi_old(a|s) * A]``; its gradient at the sampling
    parameters is the vanilla policy gradient."""
    ratio = jnp.exp(ts.policy.log_prob(params, batch.obs, batch.actions) - batch.log_probs)
    return common.weighted_mean(ratio * batch.advantages, batch.weights)


def phase_gradient(ts: TrainState, batch: Batch) -> jax.Array:
    """Vanilla policy gradient, flattened ``[num_params]``."""
    grad = jax.grad(surrogate, argnums=1)(ts, ts.params, batch)
    return ravel_pytree(grad)[0]


FISHER_STREAM = 0x666973  # folded into the state's key to draw the Fisher subsample


def fisher_subsample(ts: TrainState, batch: Batch) -> tuple[jax.Array, jax.Array]:
    """The states and weights the Fisher-vector products average over: all ``N`` of the batch, or
    ``config.fisher_samples`` of them drawn uniformly with replacement (a fresh draw each
    iteration, from the state's key) when that is fewer. Returns ``obs [M, obs_dim]``, ``weights [M]``."""
    n, m = batch.obs.shape[0], ts.config.fisher_samples
    if m <= 0 or m >= n:
        return batch.obs, batch.weights
    rows = jax.random.randint(jax.random.fold_in(ts.key, FISHER_STREAM), (m,), 0, n)
    return batch.obs[rows], batch.weights[rows]


def phase_natural_gradient(ts: TrainState, batch: Batch, grad: jax.Array) -> linalg.CGResult:
    """``F^-1 g`` by ``cg_iters`` conjugate-gradient iterations on Fisher-vector products."""
    config = ts.config
    _, unravel = ravel_pytree(ts.params)
    obs, weights = fisher_subsample(ts, batch)
    fvp = linalg.make_fisher_vector_product(
        ts.policy, ts.params, obs, weights=weights, damping=config.cg_damping, mode=config.fvp
    )
    return linalg.conjugate_gradient(lambda v: ravel_pytree(fvp(unravel(v)))[0], grad, config.cg_iters)


def normalized_step(grad: jax.Array, direction: jax.Array, delta: float) -> jax.Array:
    """Step length ``sqrt(delta / g'F^-1 g)`` along the natural direction."""
    return jnp.sqrt(delta / jnp.maximum(jnp.dot(grad, direction), 1e-20))


BACKTRACKS = 6  # halvings of the natural step tried when it overshoots its KL bound


def kl_bound(config: Config, step_size: jax.Array | float | None = None) -> jax.Array | float:
    """The mean KL an NPG step may reach: twice the ``step_size / 2`` that the normalised step
    aims at in the Fisher metric, and never more than ``max_update_kl`` (when that is set).

    ``step_size`` (e.g. a traced array, see ``update_with_step_size``) stands in for
    ``config.step_size``; the bound is then an array."""
    if step_size is None:
        return min(config.step_size, config.max_update_kl) if config.max_update_kl > 0 else config.step_size
    return jnp.minimum(step_size, config.max_update_kl) if config.max_update_kl > 0 else jnp.asarray(step_size)


def step_within_kl(
    ts: TrainState, batch: Batch, direction: jax.Array, step: jax.Array, bound: jax.Array | float | None = None
) -> tuple[Any, jax.Array, jax.Array]:
    """The longest of ``step, step/2, ... step/2^(BACKTRACKS-1)`` along ``direction`` (flat
    ``[num_params]``) whose mean KL stays within ``bound`` (default ``kl_bound(ts.config)``); all
    candidates are evaluated at once.

    Returns ``(new_params, kl [], fraction [])``: ``fraction`` is the share of ``step`` taken, 0
    (parameters unchanged, KL 0) when even the smallest candidate overshoots. The quadratic model
    behind the normalised step is usually accurate, so the full step (``fraction`` 1) is the rule.
    """
    flat_params, unravel = ravel_pytree(ts.params)
    fractions = 0.5 ** jnp.arange(BACKTRACKS, dtype=jnp.float32)
    kls = jax.vmap(lambda f: mean_kl(ts, ts.params, unravel(flat_params + f * step * direction), batch))(fractions)
    fits = kls <= (kl_bound(ts.config) if bound is None else bound)
    first = jnp.argmax(fits)
    fraction = jnp.where(jnp.any(fits), fractions[first], 0.0)
    return unravel(flat_params + fraction * step * direction), jnp.where(jnp.any(fits), kls[first], 0.0), fraction


def mean_kl(ts: TrainState, old_params: Any, new_params: Any, batch: Batch) -> jax.Array:
    """Mean KL(pi_old || pi_new) over the valid samples of ``batch``."""
    kl = ts.policy.kl(old_params, new_params, batch.obs)
    return common.weighted_mean(kl, batch.weights)


def value_predictions(ts: TrainState, obs: jax.Array) -> jax.Array:
    """``V(obs)`` in return units, ``[...]`` for normalised ``obs [..., obs_dim]``: the network's
    output, de-standardised by ``ts.value_stats`` when ``normalize_value_targets`` is set.

    PPO and A2C call this through ``phase_advantages`` with Configs that have no such field
    (their value networks always predict returns as they are), hence the ``getattr``."""
    out = ts.value_fn.apply(ts.value_params, obs)
    if getattr(ts.config, "normalize_value_targets", False):
        out = ts.value_stats.mean[0] + ts.value_stats.std[0] * out
    return out


def phase_value_fit(ts: TrainState, batch: Batch, key: jax.Array) -> tuple[TrainState, jax.Array]:
    """Minibatch Adam on the value targets; returns the state with new value params and the loss.

    With ``normalize_value_targets`` the target statistics first absorb this batch, the output
    layer is rescaled to keep its predictions (``value.preserve_outputs``; not on the first batch,
    when there is nothing to keep), and the network is fitted to the standardised targets.
    """
    config = ts.config
    value_params, value_stats, targets = ts.value_params, ts.value_stats, batch.value_targets
    if config.normalize_value_targets:
        value_stats = ts.value_stats.update(targets[:, None], batch.weights)
        preserved = value_lib.preserve_outputs(
            value_params, ts.value_stats.mean[0], ts.value_stats.std[0], value_stats.mean[0], value_stats.std[0]
        )
        # The untrained network's outputs before the first batch carry nothing worth keeping.
        seen = ts.value_stats.count > 0
        value_params = jax.tree.map(lambda p, q: jnp.where(seen, p, q), preserved, value_params)
        targets = (targets - value_stats.mean[0]) / value_stats.std[0]
    value_params, value_opt_state, loss = value_lib.fit_value(
        ts.value_fn,
        value_params,
        ts.value_opt_state,
        value_optimizer(config),
        batch.obs,
        targets,
        key,
        epochs=config.value_epochs,
        batch_size=config.value_minibatch_size,
        weights=batch.weights,
        samples_per_epoch=config.value_epoch_samples,
    )
    return ts.replace(value_params=value_params, value_opt_state=value_opt_state, value_stats=value_stats), loss


def finish_iteration(
    old: TrainState, ts: TrainState, traj: Trajectory, loss: jax.Array, metrics: dict
) -> tuple[TrainState, dict[str, jax.Array]]:
    """Common end of an iteration: reject non-finite updates, update observation statistics,
    count the iteration, and assemble the metrics.

    ``metrics["kl"]`` (the update's mean KL) above ``config.max_update_kl`` rolls the update back
    (``update_rejected`` 1). The mean policy is not evaluated here: evaluation runs between
    compiled training calls (``jaxpg.train.evaluate_state``).
    """
    limit = ts.config.max_update_kl
    within = (metrics["kl"] <= limit) if limit > 0 else True
    if "step_fraction" in metrics:  # NPG: no step within its KL bound
        within = jnp.logical_and(within, metrics["step_fraction"] > 0)
    ts, rejected = common.accept_if_finite(old, ts, loss, within)
    if ts.config.normalize_observations:
        ts = ts.replace(obs_stats=ts.obs_stats.update(traj.obs, traj.valid))
    all_metrics = {
        **common.sampling_metrics(old, traj),
        **metrics,
        "update_rejected": rejected,
        "consecutive_failures": ts.failures.astype(jnp.float32),
    }
    return ts.replace(iteration=ts.iteration + 1), all_metrics


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One NPG iteration (module docstring); pure, jittable, vmappable over seeds."""
    return update_using(ts, gae_advantages)


def update_with_step_size(ts: TrainState, step_size: jax.Array | float) -> tuple[TrainState, dict[str, jax.Array]]:
    """``update`` with the normalised step ``step_size`` (delta) in place of ``config.step_size``.

    ``Config`` is static in ``TrainState``, so a sweep over ``config.step_size`` compiles one
    program per value; ``step_size`` here may be traced, so that one program ``vmap``s over step
    sizes (and seeds), e.g. ``jax.vmap(npg.update_with_step_size)(states, jnp.array([0.01, 0.1]))``.
    The KL bound of the backtracking follows it (``kl_bound(config, step_size)``); everything else
    is ``update``'s, and ``update_with_step_size(ts, ts.config.step_size)`` gives ``update(ts)``.
    """
    return update_using(ts, gae_advantages, step_size)


def update_using(
    ts: TrainState, advantage_fn: AdvantageFn, step_size: jax.Array | float | None = None
) -> tuple[TrainState, dict[str, jax.Array]]:
    """One NPG iteration whose advantages and value targets come from ``advantage_fn``
    (``update`` is ``update_using(ts, gae_advantages)``; ``make_update`` binds another estimator),
    with the normalised step ``step_size`` when given (``update_with_step_size``), else
    ``config.step_size``."""
    old = ts
    ts, traj, key = phase_sample(ts)
    value_key, _ = jax.random.split(key)
    batch = phase_advantages(ts, traj, advantage_fn)
    grad = phase_gradient(ts, batch)
    cg = phase_natural_gradient(ts, batch, grad)
    if step_size is None:
        step = normalized_step(grad, cg.x, ts.config.step_size)
        new_params, kl, fraction = step_within_kl(ts, batch, cg.x, step)
    else:
        step = normalized_step(grad, cg.x, step_size)
        new_params, kl, fraction = step_within_kl(ts, batch, cg.x, step, kl_bound(ts.config, step_size))
    entropy = common.weighted_mean(ts.policy.entropy(ts.params, batch.obs), batch.weights)
    ts = ts.replace(params=new_params)
    ts, value_loss = phase_value_fit(ts, batch, value_key)
    metrics = {
        "kl": kl,
        "entropy": entropy,
        "step_size": fraction * step,
        "step_fraction": fraction,
        "cg_residual": cg.residual_norm,
        "grad_norm": jnp.linalg.norm(grad),
        "value_loss": value_loss,
    }
    return finish_iteration(old, ts, traj, value_loss + kl, metrics)


@functools.cache
def make_update(advantage_fn: AdvantageFn = gae_advantages) -> Callable[[TrainState], tuple[TrainState, dict]]:
    """NPG's ``update`` with the advantage estimator ``advantage_fn`` in place of GAE: a research
    hook that keeps everything else of the iteration (sampling, advantage normalisation, the
    env-major ``Batch``, natural gradient, KL-bounded step, value fit, guards and metrics).

    ``advantage_fn(ts, traj, values, next_values) -> (advantages, value_targets)`` works on
    ``[T, B]`` arrays (see ``gae_advantages``); ``phase_advantages`` flattens what it returns, so a
    custom estimator never flattens by hand. ``make_update(gae_advantages)`` is ``update``; the
    same ``advantage_fn`` gives the same function (and so the same compiled program in ``train``).
    """
    if advantage_fn is gae_advantages:
        return update

    def update_with(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
        return update_using(ts, advantage_fn)

    name = getattr(advantage_fn, "__name__", type(advantage_fn).__name__)
    update_with.__name__ = update_with.__qualname__ = f"update[{name}]"
    update_with.__doc__ = f"One NPG iteration with advantages from ``{name}`` (``npg.make_update``)."
    return update_with


def profile_phases(ts: TrainState) -> tuple[TrainState, dict[str, float]]:
    """Run one iteration as separately jitted phases and time each (seconds, after a warm-up call).

    Phases as LyceumAI reports them: ``sampling``, ``advantages`` (value predictions + GAE),
    ``gradient`` (log-likelihood / vanilla policy gradient), ``cg`` (natural gradient),
    ``value_fit``. Phase timings include dispatch; the fused ``update`` is faster than their sum.
    """
    jitted = {
        "sampling": jax.jit(phase_sample),
        "advantages": jax.jit(phase_advantages),
        "gradient": jax.jit(phase_gradient),
        "cg": jax.jit(phase_natural_gradient),
        "value_fit": jax.jit(phase_value_fit),
    }

    def run(ts: TrainState) -> tuple[TrainState, dict[str, float]]:
        timings: dict[str, float] = {}

        def timed(name: str, *args: Any) -> Any:
            start = time.perf_counter()
            out = jax.block_until_ready(jitted[name](*args))
            timings[name] = time.perf_counter() - start
            return out

        old = ts
        ts, traj, key = timed("sampling", ts)
        value_key, _ = jax.random.split(key)
        batch = timed("advantages", ts, traj)
        grad = timed("gradient", ts, batch)
        cg = timed("cg", ts, batch, grad)
        step = normalized_step(grad, cg.x, ts.config.step_size)
        flat_params, unravel = ravel_pytree(ts.params)
        ts = ts.replace(params=unravel(flat_params + step * cg.x))
        ts, _ = timed("value_fit", ts, batch, value_key)
        ts = ts.replace(iteration=old.iteration + 1)
        return ts, timings

    run(ts)  # compile every phase
    return run(ts)
