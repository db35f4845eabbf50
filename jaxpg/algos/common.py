"""What every jaxpg algorithm shares: the config fields, ``TrainState``, sampling, evaluation,
observation normalisation and the guard against non-finite updates.

An algorithm module (``npg``, ``trpo``, ``ppo`` ...) defines a ``Config`` (a frozen dataclass that
extends ``BaseConfig``), ``init(key, env, config) -> TrainState`` and
``update(train_state) -> (train_state, metrics)``. ``TrainState`` carries the env, config and
networks as static fields, so ``update`` needs nothing else and can be ``jit``-ed, ``vmap``-ed over
seeds and ``lax.scan``-ned over iterations as it is.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import optax
from flax import struct

from jaxpg import rollout as rollout_lib
from jaxpg.envs import AutoReset, Env, State
from jaxpg.policies import CategoricalPolicy, GaussianPolicy, StateStdGaussianPolicy, ValueFunction


@dataclasses.dataclass(frozen=True)
class BaseConfig:
    """Fields common to all algorithms.

    Sampling: ``num_envs`` parallel envs each run ``horizon`` steps per iteration, so an
    iteration holds ``num_envs * horizon`` samples. ``sampling="continuing"`` carries the env
    state across iterations with automatic resets (Brax / PureJaxRL); ``"episodic"`` resets all
    envs every iteration and masks steps after each episode's end (LyceumAI / mjrl).
    Evaluation: every ``eval_every`` iterations, ``eval_envs`` episodes of the mean (mode) policy
    of up to ``eval_horizon`` steps (0: the env's limit); ``eval_envs=0`` turns it off.
    """

    num_envs: int = 64
    horizon: int = 128
    sampling: str = "continuing"
    gamma: float = 0.99
    normalize_observations: bool = False
    policy: str = "gaussian"  # gaussian | state_std_gaussian (categorical is implied by a discrete env)
    policy_hidden: tuple[int, ...] = (64, 64)
    policy_activation: str = "tanh"
    policy_init: str = "glorot_uniform"
    log_std_init: float = 0.0
    value_hidden: tuple[int, ...] = (64, 64)
    value_activation: str = "tanh"
    eval_envs: int = 8
    eval_every: int = 1
    eval_horizon: int = 0

    @property
    def samples_per_iteration(self) -> int:
        return self.num_envs * self.horizon

    def validate(self, env: Env) -> None:
        """Raise ``ValueError`` with one clear line for impossible settings."""
        if self.num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {self.num_envs}")
        if self.horizon < 1:
            raise ValueError(f"horizon must be >= 1, got {self.horizon}")
        if self.sampling not in ("continuing", "episodic"):
            raise ValueError(f"sampling must be 'continuing' or 'episodic', got {self.sampling!r}")
        if self.eval_envs < 0 or self.eval_every < 1:
            raise ValueError("eval_envs must be >= 0 and eval_every >= 1")


@struct.dataclass
class RunningStats:
    """Running mean and variance of observations (parallel Welford update), ``[obs_dim]``."""

    mean: jax.Array
    var: jax.Array
    count: jax.Array

    @classmethod
    def create(cls, size: int) -> RunningStats:
        return cls(mean=jnp.zeros(size), var=jnp.ones(size), count=jnp.zeros(()))

    def update(self, batch: jax.Array, weights: jax.Array | None = None) -> RunningStats:
        """Merge a batch ``[..., obs_dim]`` (optionally weighted ``[...]``) into the statistics."""
        x = batch.reshape(-1, batch.shape[-1])
        w = jnp.ones(x.shape[0]) if weights is None else weights.reshape(-1)
        n = jnp.sum(w)
        batch_mean = jnp.sum(x * w[:, None], 0) / jnp.maximum(n, 1.0)
        batch_var = jnp.sum(jnp.square(x - batch_mean) * w[:, None], 0) / jnp.maximum(n, 1.0)
        total = self.count + n
        delta = batch_mean - self.mean
        mean = self.mean + delta * n / jnp.maximum(total, 1.0)
        m2 = self.var * self.count + batch_var * n + jnp.square(delta) * self.count * n / jnp.maximum(total, 1.0)
        var = jnp.where(total > 0, m2 / jnp.maximum(total, 1.0), 1.0)
        return RunningStats(mean=mean, var=var, count=total)

    def normalize(self, obs: jax.Array) -> jax.Array:
        """``(obs - mean) / std`` clipped to [-10, 10]; identity before any update."""
        normed = (obs - self.mean) / jnp.sqrt(self.var + 1e-8)
        return jnp.where(self.count > 0, jnp.clip(normed, -10.0, 10.0), obs)


@struct.dataclass
class TrainState:
    """Everything an algorithm carries from one iteration to the next.

    Attributes:
      params: policy parameters.
      value_params: value-function parameters (``{}`` for algorithms without a critic).
      opt_state: optimizer state of the policy (``()`` for NPG/TRPO, which step in closed form).
      value_opt_state: optimizer state of the value fit.
      env_state: ``[num_envs]`` env states (carried across iterations in continuing sampling).
      obs_stats: observation normalisation statistics (untouched when normalisation is off).
      key: PRNG key (raw ``uint32 [2]``, so that checkpoints hold plain arrays).
      iteration: ``[]`` int32, iterations completed.
      failures: ``[]`` int32, consecutive updates rejected as non-finite.
      env, config, policy, value_fn: static; not part of the pytree's leaves.
    """

    params: Any
    value_params: Any
    opt_state: Any
    value_opt_state: Any
    env_state: State
    obs_stats: RunningStats
    key: jax.Array
    iteration: jax.Array
    failures: jax.Array
    env: Env = struct.field(pytree_node=False)
    config: Any = struct.field(pytree_node=False)
    policy: Any = struct.field(pytree_node=False)
    value_fn: Any = struct.field(pytree_node=False)


def make_networks(env: Env, config: BaseConfig) -> tuple[Any, ValueFunction]:
    """The policy named by ``config`` (categorical for a discrete env) and the value function."""
    if env.discrete:
        policy: Any = CategoricalPolicy(
            num_actions=env.action_size,
            hidden=tuple(config.policy_hidden),
            activation=config.policy_activation,
            kernel_init=config.policy_init,
            bias_init=config.policy_init,
        )
    elif config.policy == "gaussian":
        policy = GaussianPolicy(
            action_size=env.action_size,
            hidden=tuple(config.policy_hidden),
            activation=config.policy_activation,
            kernel_init=config.policy_init,
            bias_init=config.policy_init,
            log_std_init=config.log_std_init,
        )
    elif config.policy == "state_std_gaussian":
        policy = StateStdGaussianPolicy(
            action_size=env.action_size,
            hidden=tuple(config.policy_hidden),
            activation=config.policy_activation,
            kernel_init=config.policy_init,
            bias_init=config.policy_init,
        )
    else:
        raise ValueError(f"unknown policy {config.policy!r}: expected 'gaussian' or 'state_std_gaussian'")
    value_fn = ValueFunction(
        hidden=tuple(config.value_hidden),
        activation=config.value_activation,
        kernel_init=config.policy_init,
        bias_init=config.policy_init,
    )
    return policy, value_fn


def init_common(
    key: jax.Array, env: Env, config: BaseConfig, opt_init: Any = None, value_opt_init: Any = None
) -> TrainState:
    """Networks, env batch and bookkeeping; ``opt_init(params)`` / ``value_opt_init(value_params)``
    build the optimizer states when the algorithm has them."""
    config.validate(env)
    key = jax.random.PRNGKey(0) if key is None else key
    policy, value_fn = make_networks(env, config)
    key, k_pol, k_val, k_env = jax.random.split(key, 4)
    params = policy.init(k_pol, env.observation_size)
    value_params = value_fn.init(k_val, env.observation_size)
    sampler_env = AutoReset(env) if config.sampling == "continuing" else env
    env_state = rollout_lib.reset_batch(sampler_env, k_env, config.num_envs)
    state = TrainState(
        params=params,
        value_params=value_params,
        opt_state=opt_init(params) if opt_init else (),
        value_opt_state=value_opt_init(value_params) if value_opt_init else (),
        env_state=env_state,
        obs_stats=RunningStats.create(env.observation_size),
        key=key,
        iteration=jnp.zeros((), jnp.int32),
        failures=jnp.zeros((), jnp.int32),
        env=env,
        config=config,
        policy=policy,
        value_fn=value_fn,
    )
    # Eagerly built leaves can share a buffer (AutoReset stores the first observation twice);
    # give each its own so that jitted updates may donate the state.
    return jax.tree.map(jnp.copy, state)


def act_fn(ts: TrainState, deterministic: bool = False) -> rollout_lib.ActFn:
    """The rollout's ``act_fn`` for ``ts``'s policy, normalising observations with ``ts.obs_stats``.

    Deterministic acting takes the mode (the "mean policy") and reports log-prob 0.
    """
    stats, policy = ts.obs_stats, ts.policy

    def act(params: Any, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        obs = stats.normalize(obs)
        if deterministic:
            return policy.mode(params, obs), jnp.zeros(obs.shape[:-1])
        return policy.sample(params, obs, key)

    return act


def sample(ts: TrainState, key: jax.Array) -> tuple[State, rollout_lib.Trajectory]:
    """One iteration's batch ``[horizon, num_envs]`` from the current policy, in the configured mode.

    Observations in the returned trajectory are raw; normalise them with ``ts.obs_stats`` (the
    statistics the batch was sampled with) before feeding networks.
    """
    config = ts.config
    if config.sampling == "continuing":
        return rollout_lib.rollout(AutoReset(ts.env), act_fn(ts), ts.params, ts.env_state, key, config.horizon)
    traj = rollout_lib.rollout_episodes(ts.env, act_fn(ts), ts.params, key, config.num_envs, config.horizon)
    return ts.env_state, traj


def evaluate(ts: TrainState, key: jax.Array, deterministic: bool = True) -> dict[str, jax.Array]:
    """Mean return, length and eval metric of ``config.eval_envs`` fresh episodes.

    ``deterministic=True`` runs the mode of the policy (LyceumAI's ``meantraj_reward``). An
    episode still running after ``eval_horizon`` steps counts with what it reached by then.
    """
    config = ts.config
    horizon = config.eval_horizon or ts.env.max_episode_steps
    traj = rollout_lib.rollout_episodes(ts.env, act_fn(ts, deterministic), ts.params, key, config.eval_envs, horizon)
    lengths = jnp.sum(traj.valid, axis=0)
    last = jnp.maximum(lengths.astype(jnp.int32) - 1, 0)
    final_metric = jnp.take_along_axis(traj.metrics["eval_metric"], last[None, :], axis=0)[0]
    return {
        "episode_return": jnp.mean(jnp.sum(traj.rewards * traj.valid, axis=0)),
        "episode_length": jnp.mean(lengths),
        "episode_eval_metric": jnp.mean(final_metric),
        "episodes": jnp.asarray(config.eval_envs, jnp.float32),
    }


def maybe_evaluate(ts: TrainState, key: jax.Array) -> dict[str, jax.Array]:
    """``evaluate`` on the iterations ``eval_every`` selects (NaN metrics on the others)."""
    config = ts.config
    nan = jnp.full((), jnp.nan)
    skipped = {
        "episode_return": nan,
        "episode_length": nan,
        "episode_eval_metric": nan,
        "episodes": jnp.zeros(()),
    }
    if config.eval_envs == 0:
        return skipped
    if config.eval_every == 1:
        return evaluate(ts, key)
    return jax.lax.cond(ts.iteration % config.eval_every == 0, lambda: evaluate(ts, key), lambda: skipped)


def sampling_metrics(ts: TrainState, traj: rollout_lib.Trajectory, eval_summary: dict) -> dict[str, jax.Array]:
    """The metrics every algorithm reports about its samples and its evaluation."""
    summary = rollout_lib.episode_summary(traj)
    return {
        "env_steps": (ts.iteration + 1).astype(jnp.float32) * ts.config.samples_per_iteration,
        "return_stochastic": summary["episode_return"],
        "return_mean_policy": eval_summary["episode_return"],
        "episode_length": summary["episode_length"],
        "eval_metric": summary["episode_eval_metric"],
        "eval_metric_mean_policy": eval_summary["episode_eval_metric"],
        "episodes": summary["episodes"],
        "nonfinite": jnp.sum(traj.metrics["nonfinite"] * traj.valid),
        "mean_reward": weighted_mean(traj.rewards, traj.valid),
    }


def weighted_mean(x: jax.Array, weights: jax.Array) -> jax.Array:
    """``[]`` mean of ``x`` over the samples ``weights`` selects (any matching shapes)."""
    return jnp.sum(x * weights) / jnp.maximum(jnp.sum(weights), 1.0)


def clip_gradients(max_grad_norm: float) -> optax.GradientTransformation:
    """Global-norm gradient clipping, or the identity when ``max_grad_norm`` is 0."""
    return optax.clip_by_global_norm(max_grad_norm) if max_grad_norm > 0 else optax.identity()


def all_finite(tree: Any) -> jax.Array:
    """``[]`` bool: every floating leaf of ``tree`` is finite."""
    leaves = [
        jnp.all(jnp.isfinite(x)) for x in jax.tree.leaves(tree) if jnp.issubdtype(jnp.asarray(x).dtype, jnp.inexact)
    ]
    return jnp.all(jnp.stack(leaves)) if leaves else jnp.array(True)


def accept_if_finite(old: TrainState, new: TrainState, loss: jax.Array) -> tuple[TrainState, jax.Array]:
    """Keep ``new`` when its parameters, optimizer states and ``loss`` are finite, else roll the
    learned state back to ``old`` (sampling state still advances) and count a failure.

    Returns the state to continue with and ``[]`` float32 1.0 where the update was rejected.
    """
    learned = (new.params, new.value_params, new.opt_state, new.value_opt_state)
    ok = all_finite(learned) & jnp.isfinite(loss)
    old_learned = (old.params, old.value_params, old.opt_state, old.value_opt_state)
    params, value_params, opt_state, value_opt_state = jax.tree.map(
        lambda n, o: jnp.where(ok, n, o), learned, old_learned
    )
    failures = jnp.where(ok, 0, new.failures + 1)
    state = new.replace(
        params=params,
        value_params=value_params,
        opt_state=opt_state,
        value_opt_state=value_opt_state,
        failures=failures,
    )
    return state, (~ok).astype(jnp.float32)
