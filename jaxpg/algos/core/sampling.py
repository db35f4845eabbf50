"""Sampling: the policy acting in the env batch, for training (``phase_sample``) and for
evaluating the mean policy (``evaluate``), and the metrics every algorithm reports about its
samples.

Several devices: traced under a mesh with an ``"envs"`` axis (``jaxpg.mesh.on_mesh``),
``sample`` and ``evaluate`` split the env batch with ``jax.shard_map``, every device stepping its
own envs (MuJoCo Warp's step is a custom call that jit's partitioner cannot split). The learning
side of ``update`` stays as written, under jit's partitioner: its reductions over the batch are
then global without any change to the algorithms, and the results equal one device's up to the
order of float summation.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import PartitionSpec

from jaxpg import distributions as D
from jaxpg import mesh
from jaxpg import rollout as rollout_lib
from jaxpg.algos.core.batch import weighted_mean
from jaxpg.algos.core.state import RunningStats, TrainState, sampler_env
from jaxpg.envs import Env, State
from jaxpg.rollout import Trajectory

TIME_ENVS = PartitionSpec(None, mesh.ENV_AXIS)  # a [T, B, ...] trajectory split over its envs
ENVS = PartitionSpec(mesh.ENV_AXIS)
REPLICATED = PartitionSpec()


def make_act(
    policy: Any,
    obs_stats: RunningStats,
    deterministic: bool = False,
    rows: tuple[jax.Array, int] | None = None,
    clipped_mean_bounds: tuple[float, float] | None = None,
) -> rollout_lib.ActFn:
    """``act(params, obs [b, obs_dim], key) -> (action [b, ...], log_prob [b])`` of ``policy``,
    normalising observations with ``obs_stats``. Deterministic acting takes the mode (the "mean
    policy") and reports log-prob 0; with ``clipped_mean_bounds = (low, high)`` it takes the
    Gaussian policy's clipped mean ``E[clip(a, low, high)]`` (``distributions.gaussian_clipped_mean``,
    ``BaseConfig.eval_action``) instead.

    ``rows = (offset, total)`` says that ``obs`` are rows ``offset .. offset + b`` of a batch of
    ``total`` envs split over devices: the action noise is then drawn for the whole batch from
    ``key`` and the own rows kept (``sample_rows``), so that every env acts as in the unsplit batch.
    """

    def act(params: Any, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        obs = obs_stats.normalize(obs)
        if deterministic and clipped_mean_bounds is not None:
            action = D.gaussian_clipped_mean(policy.dist(params, obs), *clipped_mean_bounds)
            return action, jnp.zeros(obs.shape[:-1])
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


def env_batch_mask(env: Env, env_state: State, leading: int = 0) -> Any:
    """A tree like ``env_state`` of bools: the leaf has the env axis (after ``leading`` axes).

    ``vmap`` adds the env axis to every leaf except those an env keeps once per batch: MuJoCo
    Warp's contact buffer and counters (``MjxEnv``'s ``max_batch``), which are not split.
    """
    single = jax.eval_shape(env.reset, jax.ShapeDtypeStruct((2,), jnp.uint32))
    return jax.tree.map(lambda x, s: jnp.ndim(x) == leading + len(s.shape) + 1, env_state, single)


def split_over_envs(fn: Any, num_envs: int, in_specs: Any, out_specs: Any, *args: Any) -> Any:
    """``fn(*args, rows=None)`` on one device, or under ``jax.shard_map`` over the mesh in context.

    With a mesh whose ``"envs"`` axis has ``k > 1`` devices (``jaxpg.mesh``), every device
    runs ``fn`` on its ``num_envs / k`` envs, ``rows=(offset, num_envs)`` telling it which, with
    the arguments split as ``in_specs`` say (``PartitionSpec``s over ``"envs"``; ``P()``:
    replicated, e.g. the policy parameters). The env step may be an XLA custom call (MuJoCo Warp)
    that jit's automatic partitioning cannot split; under ``shard_map`` each device calls it on
    its own envs. ``check_vma`` is off because the per-batch buffers of MuJoCo Warp (see
    ``env_batch_mask``) leave as ``P()`` though each device has its own: scratch that only that
    device's next step reads.
    """
    shards = mesh.context_env_shards()
    if shards == 1:
        return fn(*args, rows=None)
    mesh.check_divisible(num_envs, shards)
    local = num_envs // shards

    def per_device(*local_args: Any) -> Any:
        offset = jax.lax.axis_index(mesh.ENV_AXIS) * local
        return fn(*local_args, rows=(offset, num_envs))

    return jax.shard_map(per_device, in_specs=in_specs, out_specs=out_specs, check_vma=False)(*args)


def sample(ts: TrainState, key: jax.Array) -> tuple[State, Trajectory]:
    """One iteration's batch ``[horizon, num_envs]`` from the current policy, in the configured mode.

    Observations in the returned trajectory are raw; normalise them with ``ts.obs_stats`` (the
    statistics the batch was sampled with) before feeding networks. Under a mesh with an
    ``"envs"`` axis (``jaxpg.mesh.on_mesh``) each device samples its own envs
    (``split_over_envs``) with the same actions, resets and returns as the unsplit batch.
    """
    config = ts.config
    env = sampler_env(ts.env, config)
    if config.sampling == "continuing":

        def continuing(params: Any, stats: RunningStats, env_state: State, key: jax.Array, rows: Any) -> Any:
            act = make_act(ts.policy, stats, rows=rows)
            return rollout_lib.rollout(env, act, params, env_state, key, config.horizon)

        state_specs = jax.tree.map(mesh.batch_spec, env_batch_mask(env, ts.env_state))
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


def apply_sample_budget(traj: Trajectory, budget: int) -> Trajectory:
    """Keep the first ``budget`` valid samples of ``traj`` (``[T, B]`` masks), counting env by env
    as LyceumAI's sampler fills its budget; ``budget`` 0 keeps all."""
    if budget <= 0:
        return traj
    env_major = traj.valid.T.reshape(-1)
    keep = (jnp.cumsum(env_major) <= budget).reshape(traj.valid.T.shape).T
    return traj.replace(valid=traj.valid * keep)


def phase_sample(ts: TrainState) -> tuple[TrainState, Trajectory, jax.Array]:
    """An iteration's first phase: sample a ``[horizon, num_envs]`` trajectory (``sample``) within
    ``config.sample_budget``.

    Returns the state with its key and env state advanced, the trajectory, and a key for the
    iteration's later phases (split further by each algorithm as it needs).
    """
    key, sample_key, rest_key = jax.random.split(ts.key, 3)
    env_state, traj = sample(ts, sample_key)
    traj = apply_sample_budget(traj, ts.config.sample_budget)
    return ts.replace(key=key, env_state=env_state), traj, rest_key


def evaluate(ts: TrainState, key: jax.Array, deterministic: bool = True) -> dict[str, jax.Array]:
    """Mean return, length and task score of ``config.eval_envs`` fresh episodes: ``[]`` each.

    ``deterministic=True`` runs the mean policy (LyceumAI's ``meantraj_reward``): its mode, or its
    clipped mean with ``config.eval_action="clipped_mean"`` (``make_act``). An
    episode still running after ``eval_horizon`` steps counts with what it reached by then. The
    rollout stops within 50 steps of the last episode's end (``rollout.episode_totals_from``), so
    a policy that still falls early is evaluated in a fraction of the time limit's steps.
    Under a mesh with ``k`` env devices the episodes are split too, padded to a multiple of ``k``
    with repeats of the first ones, which the means leave out.
    """
    config = ts.config
    horizon = config.eval_horizon or ts.env.max_episode_steps
    count, shards = config.eval_envs, mesh.context_env_shards()
    padded = -(-count // shards) * shards
    reset_key, steps_key = jax.random.split(key)
    reset_keys = jax.random.split(reset_key, count)[np.arange(padded) % count]
    bounds = config.eval_action_bounds(ts.env)

    def run(params: Any, stats: RunningStats, reset_keys: jax.Array, key: jax.Array, rows: Any) -> Any:
        act = make_act(ts.policy, stats, deterministic, rows=rows, clipped_mean_bounds=bounds)
        return rollout_lib.episode_totals_from(ts.env, act, params, jax.vmap(ts.env.reset)(reset_keys), key, horizon)

    in_specs = (REPLICATED, REPLICATED, ENVS, REPLICATED)
    args = (ts.params, ts.obs_stats, reset_keys, steps_key)
    totals = split_over_envs(run, padded, in_specs, ENVS, *args)
    totals = jax.tree.map(lambda x: x[:count], totals)
    return {
        "episode_return": jnp.mean(totals["return"]),
        "episode_length": jnp.mean(totals["length"]),
        "episode_task_score": jnp.mean(totals["task_score"]),
        "episodes": jnp.asarray(config.eval_envs, jnp.float32),
    }


def evaluate_seeds_together(ts: TrainState, keys: jax.Array) -> dict[str, jax.Array]:
    """``evaluate`` (the mean policy) of every seed of ``ts`` in one rollout: metrics ``[S]`` each.

    ``ts``: a ``TrainState`` whose arrays carry a leading seed axis ``[S]`` (its ``env_state`` is
    not read); ``keys [S]``: each seed's evaluation key. The ``S x config.eval_envs`` envs step as
    one flat batch, with no seed axis, as MuJoCo Warp's step needs (its contact buffer is one per
    batch), each seed's policy acting on its own rows; the loop stops once every seed's episodes
    have ended, where evaluating the seeds one after another (``lax.map``) pays each seed's loop
    in turn. Each seed's episodes are those of ``evaluate(ts_s, keys[s])``: the same reset keys,
    the same actions, up to the order of float operations. Not for a mesh that splits the envs.
    """
    config = ts.config
    horizon = config.eval_horizon or ts.env.max_episode_steps
    count, seeds = config.eval_envs, keys.shape[0]
    split = jax.vmap(jax.random.split)(keys)  # [S, 2]: each seed's (reset, steps) keys, as `evaluate`
    reset_keys = jax.vmap(lambda key: jax.random.split(key, count))(split[:, 0])  # [S, count]
    reset_keys = reset_keys.reshape((seeds * count,) + reset_keys.shape[2:])
    bounds = config.eval_action_bounds(ts.env)

    def act(params_and_stats: Any, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        def act_seed(params: Any, stats: RunningStats, obs: jax.Array) -> tuple[jax.Array, jax.Array]:
            return make_act(ts.policy, stats, True, clipped_mean_bounds=bounds)(params, obs, key)

        actions, log_probs = jax.vmap(act_seed)(*params_and_stats, obs.reshape((seeds, count) + obs.shape[1:]))
        return actions.reshape((seeds * count,) + actions.shape[2:]), log_probs.reshape(seeds * count)

    starts = jax.vmap(ts.env.reset)(reset_keys)
    # The mean policy ignores the step keys; seed 0's stand for all.
    totals = rollout_lib.episode_totals_from(ts.env, act, (ts.params, ts.obs_stats), starts, split[0, 1], horizon)
    per_seed = jax.tree.map(lambda x: x.reshape(seeds, count), totals)
    return {
        "episode_return": jnp.mean(per_seed["return"], axis=1),
        "episode_length": jnp.mean(per_seed["length"], axis=1),
        "episode_task_score": jnp.mean(per_seed["task_score"], axis=1),
        "episodes": jnp.full((seeds,), config.eval_envs, jnp.float32),
    }


def sampling_metrics(ts: TrainState, traj: Trajectory) -> dict[str, jax.Array]:
    """The metrics every algorithm reports about the samples ``traj`` that ``ts`` drew (the
    episodes that ended in them), ``[]`` each.

    ``physics_overflow`` counts the env steps whose physics solve hit a capacity or iteration
    limit (MuJoCo Warp reports these; always 0 with MJX's JAX implementation).
    """
    summary = rollout_lib.episode_summary(traj)
    return {
        "env_steps": (ts.iteration + 1).astype(jnp.float32) * ts.config.samples_per_iteration,
        "return_stochastic": summary["episode_return"],
        "episode_length": summary["episode_length"],
        "task_score": summary["episode_task_score"],
        "episodes": summary["episodes"],
        "nonfinite": jnp.sum(traj.metrics["nonfinite"] * traj.valid),
        "invalid_action": jnp.sum(traj.metrics["invalid_action"] * traj.valid),
        "physics_overflow": jnp.sum(traj.metrics["physics_overflow"] * traj.valid),
        "mean_reward": weighted_mean(traj.rewards, traj.valid),
    }
