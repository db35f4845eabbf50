"""What every jaxpg algorithm shares: the config fields, ``TrainState``, sampling, evaluation,
observation normalisation and the guard against non-finite updates.

An algorithm module (``npg``, ``trpo``, ``ppo`` ...) defines a ``Config`` (a frozen dataclass that
extends ``BaseConfig``), ``init(key, env, config) -> TrainState`` and
``update(train_state) -> (train_state, metrics)``. ``TrainState`` carries the env, config and
networks as static fields, so ``update`` needs nothing else and can be ``jit``-ed, ``vmap``-ed over
seeds and ``lax.scan``-ned over iterations as it is.

Several devices: traced under a mesh with an ``"envs"`` axis (``jaxpg.distributed.on_mesh``),
``sample`` and ``evaluate`` split the env batch with ``jax.shard_map``, every device stepping its
own envs (MuJoCo Warp's step is a custom call that jit's partitioner cannot split). The learning
side of ``update`` stays as written, under jit's partitioner: its reductions over the batch are
then global without any change to the algorithms, and the results equal one device's up to the
order of float summation.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct
from jax.sharding import PartitionSpec

from jaxpg import distributed
from jaxpg import rollout as rollout_lib
from jaxpg.envs import AutoReset, Env, State
from jaxpg.policies import ValueFunction, make_policy

POLICY_NAMES = ("gaussian", "state_std_gaussian")  # categorical is implied by a discrete env


@dataclasses.dataclass(frozen=True)
class BaseConfig:
    """Fields common to all algorithms.

    Sampling: ``num_envs`` parallel envs each run ``horizon`` steps per iteration, so an
    iteration holds ``num_envs * horizon`` samples. ``sampling="continuing"`` carries the env
    state across iterations with automatic resets (Brax / PureJaxRL); ``"episodic"`` resets all
    envs every iteration and masks steps after each episode's end (LyceumAI / mjrl).
    Evaluation (``jaxpg.train``, between compiled training calls, never inside ``update``): after
    every ``eval_every``-th iteration and after the last one, ``eval_envs`` episodes of the mean
    (mode) policy of up to ``eval_horizon`` steps (0: the env's limit); ``eval_envs=0`` turns it off.
    Trust-region guard: an update whose mean KL(old || new) over its batch exceeds
    ``max_update_kl`` is rolled back and counted in ``update_rejected`` (NPG first shrinks its
    step, see ``npg.update``); healthy updates move the policy by 0.001-0.1 nats. 0 turns it off.
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
    eval_every: int = 10
    eval_horizon: int = 0
    max_update_kl: float = 1.0

    @property
    def samples_per_iteration(self) -> int:
        return self.num_envs * self.horizon

    def validate(self, env: Env) -> None:
        """Raise ``ValueError`` with one clear line for impossible settings (every field checked)."""
        from jaxpg.networks import ACTIVATIONS, KERNEL_INITS

        if self.num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {self.num_envs}")
        if self.horizon < 1:
            raise ValueError(f"horizon must be >= 1, got {self.horizon}")
        if self.sampling not in ("continuing", "episodic"):
            raise ValueError(f"sampling must be 'continuing' or 'episodic', got {self.sampling!r}")
        if not 0 <= self.gamma <= 1:
            raise ValueError(f"gamma must be in [0, 1], got {self.gamma}")
        if self.policy not in POLICY_NAMES:
            raise ValueError(f"unknown policy {self.policy!r}; expected one of {', '.join(POLICY_NAMES)}")
        for name in ("policy_activation", "value_activation"):
            if getattr(self, name) not in ACTIVATIONS:
                raise ValueError(f"unknown {name} {getattr(self, name)!r}; expected one of {', '.join(ACTIVATIONS)}")
        if self.policy_init not in KERNEL_INITS:
            raise ValueError(f"unknown policy_init {self.policy_init!r}; expected one of {', '.join(KERNEL_INITS)}")
        for name in ("policy_hidden", "value_hidden"):
            if any(int(size) < 1 for size in getattr(self, name)):
                raise ValueError(f"{name} must be positive layer sizes, got {' '.join(map(str, getattr(self, name)))}")
        if not math.isfinite(self.log_std_init):
            raise ValueError(f"log_std_init must be finite, got {self.log_std_init}")
        if self.eval_envs < 0 or self.eval_every < 1 or self.eval_horizon < 0:
            raise ValueError(
                f"eval_envs and eval_horizon must be >= 0 and eval_every >= 1, got "
                f"{self.eval_envs}, {self.eval_horizon}, {self.eval_every}"
            )
        if not self.max_update_kl >= 0:
            raise ValueError(f"max_update_kl must be >= 0 (0: no check), got {self.max_update_kl}")


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
      opt_state: optimizer state of the policy (``()`` for NPG/TRPO, which step in closed form).
      value_opt_state: optimizer state of the value fit.
      env_state: ``[num_envs]`` env states (carried across iterations in continuing sampling).
      obs_stats: observation normalisation statistics (untouched when normalisation is off).
      value_stats: ``[1]`` running statistics of the value targets, which the value network
        predicts standardised when the algorithm normalises them (NPG's
        ``normalize_value_targets``); untouched otherwise.
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
    value_stats: RunningStats
    key: jax.Array
    iteration: jax.Array
    failures: jax.Array
    env: Env = struct.field(pytree_node=False)
    config: Any = struct.field(pytree_node=False)
    policy: Any = struct.field(pytree_node=False)
    value_fn: Any = struct.field(pytree_node=False)


def make_networks(env: Env, config: BaseConfig) -> tuple[Any, ValueFunction]:
    """The policy named by ``config`` (categorical for a discrete env) and the value function."""
    name = "categorical" if env.discrete else config.policy
    layers = dict(
        hidden=tuple(config.policy_hidden),
        activation=config.policy_activation,
        kernel_init=config.policy_init,
        bias_init=config.policy_init,
    )
    if name == "gaussian":
        layers["log_std_init"] = config.log_std_init
    policy = make_policy(name, env.action_size, env.discrete, **layers)
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


def act_fn(ts: TrainState, deterministic: bool = False) -> rollout_lib.ActFn:
    """The rollout's ``act_fn`` for ``ts``'s policy, normalising observations with ``ts.obs_stats``.

    Deterministic acting takes the mode (the "mean policy") and reports log-prob 0.
    """
    return make_act(ts.policy, ts.obs_stats, deterministic)


def make_act(
    policy: Any, obs_stats: RunningStats, deterministic: bool = False, rows: tuple[jax.Array, int] | None = None
) -> rollout_lib.ActFn:
    """``act(params, obs [b, obs_dim], key) -> (action [b, ...], log_prob [b])`` of ``policy``.

    ``rows = (offset, total)`` says that ``obs`` are rows ``offset .. offset + b`` of a batch of
    ``total`` envs split over devices: the action noise is then drawn for the whole batch from
    ``key`` and the own rows kept (``sample_rows``), so that every env acts as in the unsplit batch.
    """

    def act(params: Any, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        obs = obs_stats.normalize(obs)
        if deterministic:
            return policy.mode(params, obs), jnp.zeros(obs.shape[:-1])
        if rows is None:
            return policy.sample(params, obs, key)
        dist = policy.dist(params, obs)
        action = sample_rows(policy, dist, key, *rows)
        return action, policy.dist_log_prob(dist, action)

    return act


def sample_rows(policy: Any, dist: Any, key: jax.Array, offset: jax.Array, total: int) -> jax.Array:
    """Rows ``offset .. offset + b`` of ``policy.dist_sample`` over a ``[total]`` batch whose rows
    there are ``dist`` (every leaf ``[b, ...]``, as ``Policy.dist`` returns them).

    The noise of JAX's random functions is a function of the key and the element's index in the
    drawn shape, so drawing ``[total, ...]`` and keeping the own rows gives each row the noise it
    has in the unsplit batch, bit for bit. The other rows are zeros (a valid distribution); the
    extra work is the random numbers of ``total`` rows, small beside a physics step.
    """
    rows = jax.tree.leaves(dist)[0].shape[0]

    def widen(x: jax.Array) -> jax.Array:
        return jax.lax.dynamic_update_slice_in_dim(jnp.zeros((total, *x.shape[1:]), x.dtype), x, offset, axis=0)

    wide = policy.dist_sample(jax.tree.map(widen, dist), key)
    return jax.lax.dynamic_slice_in_dim(wide, offset, rows, axis=0)


def sampler_env(ts: TrainState) -> Env:
    """The env that ``sample`` steps: ``AutoReset(env)`` in continuing sampling, else ``env``."""
    return AutoReset(ts.env) if ts.config.sampling == "continuing" else ts.env


def env_batch_mask(env: Env, env_state: State, leading: int = 0) -> Any:
    """A tree like ``env_state`` of bools: the leaf has the env axis (after ``leading`` axes).

    ``vmap`` adds the env axis to every leaf except those an env keeps once per batch: MuJoCo
    Warp's contact buffer and counters (``MjxEnv``'s ``max_batch``), which are not split.
    """
    single = jax.eval_shape(env.reset, jax.ShapeDtypeStruct((2,), jnp.uint32))
    return jax.tree.map(lambda x, s: jnp.ndim(x) == leading + len(s.shape) + 1, env_state, single)


def split_over_envs(fn: Any, num_envs: int, in_specs: Any, out_specs: Any, *args: Any) -> Any:
    """``fn(*args, rows=None)`` on one device, or under ``jax.shard_map`` over the mesh in context.

    With a mesh whose ``"envs"`` axis has ``k > 1`` devices (``jaxpg.distributed``), every device
    runs ``fn`` on its ``num_envs / k`` envs, ``rows=(offset, num_envs)`` telling it which, with
    the arguments split as ``in_specs`` say (``PartitionSpec``s over ``"envs"``; ``P()``:
    replicated, e.g. the policy parameters). The env step may be an XLA custom call (MuJoCo Warp)
    that jit's automatic partitioning cannot split; under ``shard_map`` each device calls it on
    its own envs. ``check_vma`` is off because the per-batch buffers of MuJoCo Warp (see
    ``env_batch_mask``) leave as ``P()`` though each device has its own: scratch that only that
    device's next step reads.
    """
    shards = distributed.context_env_shards()
    if shards == 1:
        return fn(*args, rows=None)
    distributed.check_divisible(num_envs, shards)
    local = num_envs // shards

    def per_device(*local_args: Any) -> Any:
        offset = jax.lax.axis_index(distributed.ENV_AXIS) * local
        return fn(*local_args, rows=(offset, num_envs))

    return jax.shard_map(per_device, in_specs=in_specs, out_specs=out_specs, check_vma=False)(*args)


TIME_ENVS = PartitionSpec(None, distributed.ENV_AXIS)  # a [T, B, ...] trajectory split over its envs
ENVS = PartitionSpec(distributed.ENV_AXIS)
REPLICATED = PartitionSpec()


def sample(ts: TrainState, key: jax.Array) -> tuple[State, rollout_lib.Trajectory]:
    """One iteration's batch ``[horizon, num_envs]`` from the current policy, in the configured mode.

    Observations in the returned trajectory are raw; normalise them with ``ts.obs_stats`` (the
    statistics the batch was sampled with) before feeding networks. Under a mesh with an
    ``"envs"`` axis (``jaxpg.distributed.on_mesh``) each device samples its own envs
    (``split_over_envs``) with the same actions, resets and returns as the unsplit batch.
    """
    config = ts.config
    env = sampler_env(ts)
    if config.sampling == "continuing":

        def continuing(params: Any, stats: RunningStats, env_state: State, key: jax.Array, rows: Any) -> Any:
            act = make_act(ts.policy, stats, rows=rows)
            return rollout_lib.rollout(env, act, params, env_state, key, config.horizon)

        state_specs = jax.tree.map(distributed.batch_spec, env_batch_mask(env, ts.env_state))
        in_specs = (REPLICATED, REPLICATED, state_specs, REPLICATED)
        args = (ts.params, ts.obs_stats, ts.env_state, key)
        return split_over_envs(continuing, config.num_envs, in_specs, (state_specs, TIME_ENVS), *args)
    reset_key, steps_key = jax.random.split(key)

    def episodic(params: Any, stats: RunningStats, reset_keys: jax.Array, key: jax.Array, rows: Any) -> Any:
        act = make_act(ts.policy, stats, rows=rows)
        return rollout_lib.rollout_episodes_from(env, act, params, jax.vmap(env.reset)(reset_keys), key, config.horizon)

    in_specs = (REPLICATED, REPLICATED, ENVS, REPLICATED)
    args = (ts.params, ts.obs_stats, jax.random.split(reset_key, config.num_envs), steps_key)
    return ts.env_state, split_over_envs(episodic, config.num_envs, in_specs, TIME_ENVS, *args)


def evaluate(ts: TrainState, key: jax.Array, deterministic: bool = True) -> dict[str, jax.Array]:
    """Mean return, length and eval metric of ``config.eval_envs`` fresh episodes.

    ``deterministic=True`` runs the mode of the policy (LyceumAI's ``meantraj_reward``). An
    episode still running after ``eval_horizon`` steps counts with what it reached by then.
    Under a mesh with ``k`` env devices the episodes are split too, padded to a multiple of ``k``
    with repeats of the first ones, which the means leave out.
    """
    config = ts.config
    horizon = config.eval_horizon or ts.env.max_episode_steps
    count, shards = config.eval_envs, distributed.context_env_shards()
    padded = -(-count // shards) * shards
    reset_key, steps_key = jax.random.split(key)
    reset_keys = jax.random.split(reset_key, count)[np.arange(padded) % count]

    def run(params: Any, stats: RunningStats, reset_keys: jax.Array, key: jax.Array, rows: Any) -> Any:
        act = make_act(ts.policy, stats, deterministic, rows=rows)
        return rollout_lib.rollout_episodes_from(ts.env, act, params, jax.vmap(ts.env.reset)(reset_keys), key, horizon)

    in_specs = (REPLICATED, REPLICATED, ENVS, REPLICATED)
    args = (ts.params, ts.obs_stats, reset_keys, steps_key)
    traj = split_over_envs(run, padded, in_specs, TIME_ENVS, *args)
    traj = jax.tree.map(lambda x: x[:, :count], traj)
    lengths = jnp.sum(traj.valid, axis=0)
    last = jnp.maximum(lengths.astype(jnp.int32) - 1, 0)
    final_metric = jnp.take_along_axis(traj.metrics["eval_metric"], last[None, :], axis=0)[0]
    return {
        "episode_return": jnp.mean(jnp.sum(traj.rewards * traj.valid, axis=0)),
        "episode_length": jnp.mean(lengths),
        "episode_eval_metric": jnp.mean(final_metric),
        "episodes": jnp.asarray(config.eval_envs, jnp.float32),
    }


def sampling_metrics(ts: TrainState, traj: rollout_lib.Trajectory) -> dict[str, jax.Array]:
    """The metrics every algorithm reports about its samples (the episodes that ended in them).

    ``physics_overflow`` counts the env steps whose physics solve hit a capacity or iteration
    limit (MuJoCo Warp reports these; always 0 with MJX's JAX implementation).
    """
    summary = rollout_lib.episode_summary(traj)
    return {
        "env_steps": (ts.iteration + 1).astype(jnp.float32) * ts.config.samples_per_iteration,
        "return_stochastic": summary["episode_return"],
        "episode_length": summary["episode_length"],
        "eval_metric": summary["episode_eval_metric"],
        "episodes": summary["episodes"],
        "nonfinite": jnp.sum(traj.metrics["nonfinite"] * traj.valid),
        "invalid_action": jnp.sum(traj.metrics["invalid_action"] * traj.valid),
        "physics_overflow": jnp.sum(traj.metrics["physics_overflow"] * traj.valid),
        "mean_reward": weighted_mean(traj.rewards, traj.valid),
    }


# ``[T, B, ...] -> [B * T, ...]`` (env-major); defined in ``jaxpg.rollout`` beside ``Trajectory``.
flatten_samples = rollout_lib.flatten_samples


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


# Euclidean norm of all leaves of a pytree together: optax's (tree_norm from optax 0.2.5, where
# global_norm became deprecated; global_norm before).
tree_norm = getattr(optax.tree_utils, "tree_norm", None) or optax.global_norm


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
