"""``TrainState``, what every algorithm carries from one iteration to the next, and how ``init``
builds it: the networks a config names, the env batch, the optimizer states.

``TrainState`` carries the env, config and networks as static fields, so ``update`` needs nothing
else and can be ``jit``-ed, ``vmap``-ed over seeds and ``lax.scan``-ned over iterations as it is.
"""

from __future__ import annotations

import math
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from jaxpg import rollout as rollout_lib
from jaxpg.algos.core.config import BaseConfig
from jaxpg.envs import AutoReset, Env, State
from jaxpg.networks import CONV_TORSOS, ConvTorso
from jaxpg.policies import ValueFunction, make_policy


@struct.dataclass
class RunningStats:
    """Running mean and variance of observations (parallel Welford update), ``[obs_dim]``; also
    used for the ``[1]`` value targets."""

    mean: jax.Array
    var: jax.Array
    count: jax.Array

    @classmethod
    def create(cls, size: int) -> RunningStats:
        return cls(mean=jnp.zeros(size), var=jnp.ones(size), count=jnp.zeros(()))

    def update(self, batch: jax.Array, weights: jax.Array | None = None) -> RunningStats:
        """Merge a batch ``[..., obs_dim]`` (optionally weighted ``[...]``) into the statistics."""
        # Sums over the leading axes, not a reshape: a batch sharded over envs stays sharded.
        axes = tuple(range(batch.ndim - 1))
        w = jnp.ones(batch.shape[:-1]) if weights is None else jnp.broadcast_to(weights, batch.shape[:-1])
        n = jnp.sum(w)
        batch_mean = jnp.sum(batch * w[..., None], axes) / jnp.maximum(n, 1.0)
        batch_var = jnp.sum(jnp.square(batch - batch_mean) * w[..., None], axes) / jnp.maximum(n, 1.0)
        total = self.count + n
        delta = batch_mean - self.mean
        mean = self.mean + delta * n / jnp.maximum(total, 1.0)
        m2 = self.var * self.count + batch_var * n + jnp.square(delta) * self.count * n / jnp.maximum(total, 1.0)
        var = jnp.where(total > 0, m2 / jnp.maximum(total, 1.0), 1.0)
        return RunningStats(mean=mean, var=var, count=total)

    @property
    def std(self) -> jax.Array:
        """``sqrt(var + 1e-8)``, ``[size]``."""
        return jnp.sqrt(self.var + 1e-8)

    def normalize(self, obs: jax.Array) -> jax.Array:
        """``(obs - mean) / std`` clipped to [-10, 10]; identity before any update."""
        normed = (obs - self.mean) / self.std
        return jnp.where(self.count > 0, jnp.clip(normed, -10.0, 10.0), obs)


@struct.dataclass
class TrainState:
    """Everything an algorithm carries from one iteration to the next.

    Attributes:
      params: policy parameters.
      value_params: value-function parameters (``{}`` for algorithms without a critic).
      opt_state: optimizer state of the policy (``()`` for NPG/TRPO, which step in closed form;
        for PPO/A2C the state of one optimizer over policy and value together).
      value_opt_state: optimizer state of the value fit (``()`` where there is none).
      env_state: ``[num_envs]`` env states (carried across iterations in continuing sampling).
      obs_stats: observation normalisation statistics (untouched when normalisation is off).
      value_stats: ``[1]`` running statistics of the value targets, which the value network
        predicts standardised when ``config.normalize_value_targets`` is set; untouched otherwise.
      key: PRNG key (raw ``uint32 [2]``, so that checkpoints hold plain arrays).
      iteration: ``[]`` int32, iterations completed.
      failures: ``[]`` int32, consecutive updates rejected as non-finite.
      env, config, policy, value_fn: static; not part of the pytree's leaves.
      reward_normalizer: the ``core.RewardNormalizer`` of an actor-critic config with
        ``normalize_rewards``; ``()`` otherwise (no leaves, so the checkpoints of every other
        config keep their layout).
      hparams: ``()``, the update reads every number from ``config``; or the ``[]`` arrays of
        ``core.hyperparameters`` (``core.with_hyperparameters``), which it reads in place of the
        config's traced fields, so that one program trains many configurations (``core.hparams``).
    """

    params: Any
    value_params: Any
    opt_state: Any
    value_opt_state: Any
    env_state: State
    obs_stats: RunningStats
    value_stats: RunningStats
    key: jax.Array
    iteration: jax.Array
    failures: jax.Array
    env: Env = struct.field(pytree_node=False)
    config: Any = struct.field(pytree_node=False)
    policy: Any = struct.field(pytree_node=False)
    value_fn: Any = struct.field(pytree_node=False)
    reward_normalizer: Any = ()
    hparams: Any = ()


def make_networks(env: Env, config: BaseConfig) -> tuple[Any, ValueFunction]:
    """The policy named by ``config`` (categorical for a discrete env) and the value function,
    both initialised by ``config.network_init`` (the policy's last layer then multiplied by
    ``config.policy_head_scale``), each with its own ``config.conv_torso`` if any
    (orthogonal kernels get the ReLU gain sqrt(2) there)."""
    name = "categorical" if env.discrete else config.policy
    conv = None
    if config.conv_torso != "none":
        gain = 2.0**0.5 if config.network_init == "orthogonal" else 1.0
        conv = ConvTorso(env.image_shape, CONV_TORSOS[config.conv_torso], config.network_init, gain)
    layers = dict(
        hidden=tuple(config.policy_hidden),
        activation=config.policy_activation,
        kernel_init=config.network_init,
        bias_init=config.network_init,
    )
    if conv is not None:
        layers["conv"] = conv
    if config.policy_head_scale != 1.0:
        layers["final_kernel_scale"] = config.policy_head_scale
    if name == "gaussian":
        layers["log_std_init"] = config.log_std_init
    policy = make_policy(name, env.action_size, env.discrete, **layers)
    value_fn = ValueFunction(
        hidden=tuple(config.value_hidden),
        activation=config.value_activation,
        kernel_init=config.network_init,
        bias_init=config.network_init,
        conv=conv,
    )
    return policy, value_fn


def memory_lower_bound(config: BaseConfig, env: Env) -> dict[str, int]:
    """Bytes that training one seed with ``config`` on ``env`` holds at once, at the least.

    ``parameters``: the policy and value networks (the shapes their ``init`` gives, traced
    abstractly: nothing is allocated); ``rollout``: the ``num_envs * horizon`` samples of an
    iteration, each its observation, action, reward, done flag, log-probability and value
    (float32); ``env_states``: one observation per training and evaluation env; ``total``:
    their sum. Optimizer states, activations, gradients and the simulator's state come on top,
    so a config whose bound exceeds the memory there is cannot run.
    """
    policy, value_fn = make_networks(env, config)
    obs_size = env.observation_size
    key = jax.ShapeDtypeStruct((2,), np.uint32)
    shapes = jax.eval_shape(lambda k: (policy.init(k, obs_size), value_fn.init(k, obs_size)), key)
    parameters = sum(math.prod(x.shape) * np.dtype(x.dtype).itemsize for x in jax.tree.leaves(shapes))
    action_numbers = 1 if env.discrete else env.action_size
    rollout = 4 * config.num_envs * config.horizon * (obs_size + action_numbers + 4)
    env_states = 4 * (config.num_envs + config.eval_envs) * obs_size
    return {
        "parameters": parameters,
        "rollout": rollout,
        "env_states": env_states,
        "total": parameters + rollout + env_states,
    }


def sampler_env(env: Env, config: BaseConfig) -> Env:
    """The env that sampling steps: ``AutoReset(env)`` in continuing sampling, else ``env``."""
    return AutoReset(env) if config.sampling == "continuing" else env


def init_state(
    key: jax.Array,
    env: Env,
    config: BaseConfig,
    optimizer: optax.GradientTransformation | None = None,
    value_optimizer: optax.GradientTransformation | None = None,
) -> TrainState:
    """A validated config's fresh ``TrainState``: networks, env batch and bookkeeping, with the
    states of ``optimizer`` over the policy parameters and ``value_optimizer`` over the value
    parameters where the algorithm has them (``()`` otherwise)."""
    config.validate(env)
    key = jax.random.PRNGKey(0) if key is None else key
    policy, value_fn = make_networks(env, config)
    key, k_pol, k_val, k_env = jax.random.split(key, 4)
    params = policy.init(k_pol, env.observation_size)
    value_params = value_fn.init(k_val, env.observation_size)
    env_state = rollout_lib.reset_batch(sampler_env(env, config), k_env, config.num_envs)
    state = TrainState(
        params=params,
        value_params=value_params,
        opt_state=optimizer.init(params) if optimizer is not None else (),
        value_opt_state=value_optimizer.init(value_params) if value_optimizer is not None else (),
        env_state=env_state,
        obs_stats=RunningStats.create(env.observation_size),
        value_stats=RunningStats.create(1),
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


def clip_gradients(max_grad_norm: float) -> optax.GradientTransformation:
    """Global-norm gradient clipping, or the identity when ``max_grad_norm`` is 0."""
    return optax.clip_by_global_norm(max_grad_norm) if max_grad_norm > 0 else optax.identity()
