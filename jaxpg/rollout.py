"""Batched sampling: ``lax.scan`` over time, ``vmap`` over environments.

Two modes, both pure and jittable, both usable under an outer ``vmap`` (several seeds in one
program) and with the env batch sharded over devices (the batch axis is the one to shard):

* ``rollout`` -- *continuing* sampling (Brax, PureJaxRL): envs reset themselves when an episode
  ends (the env must be wrapped in ``AutoReset``), the env state is carried from one iteration to
  the next, and every iteration samples a fixed ``horizon``.
* ``rollout_episodes`` -- *episodic* sampling (LyceumAI, mjrl): every env is reset at the start,
  runs ``horizon`` steps without reset, and ``valid`` masks the steps after its episode ended.

A third, ``episode_totals_from``, steps like ``rollout_episodes_from`` but keeps only each
episode's return, length and final task score, and stops once every episode has ended: the
in-run mean-policy evaluation (``jaxpg.algos.core.evaluate``).

The policy enters as ``act_fn(params, obs [B, obs_dim], key) -> (action [B, ...], log_prob [B])``.
Training, mean-policy evaluation (``jaxpg.algos.core.evaluate``, ``jaxpg.evaluate``) and videos
all sample through these functions; what a caller needs beyond the transitions (a video needs
the physics state, ``qpos`` and ``qvel``) it asks for with ``record_fn(state) -> {name: [B, ...]}``,
whose outputs of every step's resulting state land in ``Trajectory.extras``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from jaxpg.envs.base import Env, State

ActFn = Callable[[Any, jax.Array, jax.Array], tuple[jax.Array, jax.Array]]
RecordFn = Callable[[State], dict[str, jax.Array]]


@struct.dataclass
class Trajectory:
    """A batch of transitions, time-major: every field is ``[T, B, ...]``.

    ``flatten_samples`` turns a field (or anything else laid out ``[T, B, ...]``, e.g. advantages)
    into the flat ``[B * T, ...]`` rows of the algorithms' training batches; use it, and not a
    reshape, so that the rows of every flattened array line up.

    Attributes:
      obs: ``[T, B, obs_dim]`` observation the action was taken in.
      actions: ``[T, B, act_dim]`` (continuous) or ``[T, B]`` int32 (discrete).
      log_probs: ``[T, B]`` log-probability of the action under the sampling policy.
      rewards: ``[T, B]``.
      terminated: ``[T, B]`` bool, the task ended at this step (no bootstrap).
      truncated: ``[T, B]`` bool, the time limit ended the episode (bootstrap from ``next_obs``).
      next_obs: ``[T, B, obs_dim]`` observation after the step, *before* any automatic reset:
        the final observation of an episode that ended here.
      valid: ``[T, B]`` float32, 1 for real transitions, 0 for steps after an episode ended in
        episodic sampling (always 1 in continuing sampling).
      metrics: ``[T, B]`` per-step env metrics (``episode_return``, ``episode_done`` ...).
      extras: ``[T, B, ...]`` what the sampler's ``record_fn`` read from each step's resulting
        state (in continuing sampling, the state after any automatic reset); ``{}`` without a
        ``record_fn``.
    """

    obs: jax.Array
    actions: jax.Array
    log_probs: jax.Array
    rewards: jax.Array
    terminated: jax.Array
    truncated: jax.Array
    next_obs: jax.Array
    valid: jax.Array
    metrics: dict[str, jax.Array]
    extras: dict[str, jax.Array] = struct.field(default_factory=dict)

    @property
    def dones(self) -> jax.Array:
        """``[T, B]`` bool: an episode ended at this step."""
        return jnp.logical_or(self.terminated, self.truncated)


def reset_batch(env: Env, key: jax.Array, num_envs: int) -> State:
    """``num_envs`` independent initial states, ``[num_envs, ...]`` on every leaf."""
    return jax.vmap(env.reset)(jax.random.split(key, num_envs))


def _transition(
    env: Env, act_fn: ActFn, params: Any, state: State, key: jax.Array, record_fn: RecordFn | None = None
) -> tuple[State, dict]:
    """One batched env step from ``state [B]``; returns the new state and the step's record
    (``extras``: ``record_fn`` of the new state, when given)."""
    actions, log_probs = act_fn(params, state.obs, key)
    next_state = jax.vmap(env.step)(state, actions)
    next_obs = next_state.info.get("final_obs", next_state.obs)
    record = dict(
        obs=state.obs,
        actions=actions,
        log_probs=log_probs,
        rewards=next_state.reward,
        terminated=next_state.terminated,
        truncated=next_state.truncated,
        next_obs=next_obs,
        metrics=next_state.metrics,
        extras={} if record_fn is None else record_fn(next_state),
    )
    return next_state, record


def rollout(
    env: Env,
    act_fn: ActFn,
    params: Any,
    env_state: State,
    key: jax.Array,
    horizon: int,
    record_fn: RecordFn | None = None,
    unroll: int = 1,
) -> tuple[State, Trajectory]:
    """Continuing sampling of ``horizon`` steps from ``env_state [B]``.

    ``env`` must reset itself (``AutoReset``). Returns the env state to continue from and a
    ``Trajectory`` of ``[horizon, B]`` transitions with ``valid`` all ones (``extras``:
    ``record_fn`` of each step's resulting state, after any automatic reset). ``unroll`` (static)
    runs that many env steps per iteration of the compiled loop (``lax.scan``'s ``unroll``): the
    same numbers, fewer loop iterations for the host to drive, a longer compilation. (For MuJoCo
    Warp's Hopper on a GPU, 4 was slower than 1: docs/benchmarks_archive.md, section AI.)
    """

    def body(state: State, step_key: jax.Array) -> tuple[State, dict]:
        return _transition(env, act_fn, params, state, step_key, record_fn)

    env_state, records = jax.lax.scan(body, env_state, jax.random.split(key, horizon), unroll=unroll)
    valid = jnp.ones_like(records["rewards"])
    return env_state, Trajectory(valid=valid, **records)


def rollout_episodes(
    env: Env,
    act_fn: ActFn,
    params: Any,
    key: jax.Array,
    num_envs: int,
    horizon: int,
    record_fn: RecordFn | None = None,
) -> Trajectory:
    """Episodic sampling: reset ``num_envs`` envs, run ``horizon`` steps, mask after each end.

    ``env`` must *not* reset itself. Returns a ``[horizon, num_envs]`` ``Trajectory`` whose
    ``valid`` is 1 up to and including the step where each env's first episode ended
    (``extras``: ``record_fn`` of each step's resulting state; ``with_initial`` puts the same read
    from the reset states in front).
    """
    reset_key, steps_key = jax.random.split(key)
    state = reset_batch(env, reset_key, num_envs)
    return rollout_episodes_from(env, act_fn, params, state, steps_key, horizon, record_fn)


def rollout_episodes_from(
    env: Env,
    act_fn: ActFn,
    params: Any,
    state: State,
    key: jax.Array,
    horizon: int,
    record_fn: RecordFn | None = None,
) -> Trajectory:
    """``rollout_episodes`` from given initial states ``state [B]`` (e.g. a device's share of a
    batch reset from its own keys); ``key`` draws the steps. Returns ``[horizon, B]``."""

    def body(carry: tuple[State, jax.Array], step_key: jax.Array) -> tuple[tuple[State, jax.Array], dict]:
        state, alive = carry
        next_state, record = _transition(env, act_fn, params, state, step_key, record_fn)
        record["valid"] = alive.astype(jnp.float32)
        alive = jnp.logical_and(alive, ~next_state.done)
        return (next_state, alive), record

    alive = jnp.ones(state.obs.shape[:1], bool)
    _, records = jax.lax.scan(body, (state, alive), jax.random.split(key, horizon))
    return Trajectory(**records)


def episode_totals_from(
    env: Env,
    act_fn: ActFn,
    params: Any,
    state: State,
    key: jax.Array,
    horizon: int,
    check_every: int = 50,
) -> dict[str, jax.Array]:
    """What ``rollout_episodes_from`` summarises for an evaluation, without keeping the steps, and
    stopping once every episode has ended.

    Steps ``state [B]`` as ``rollout_episodes_from`` does (the same per-step keys), in chunks of
    ``check_every`` steps (static) inside a ``lax.while_loop`` that stops after the chunk in which
    the last episode ended, or at ``horizon``: with the default 50, episodes that have all ended
    by step 180 cost 200 steps, not ``horizon``; ones that run to the time limit cost one
    loop-condition read per chunk more. Returns ``[B]`` each: ``return`` (sum of the rewards up to and including
    each episode's last step), ``length`` (its steps, float32) and ``task_score`` (the env's
    ``task_score`` metric at that last step): the same as ``sum(rewards * valid)``,
    ``sum(valid)`` and ``last_valid(traj, metrics["task_score"])`` of the full rollout, up to the
    order of the float additions.
    """
    chunk = max(1, min(int(check_every), horizon))
    chunks = -(-horizon // chunk)
    step_keys = jax.random.split(key, horizon)
    padding = chunks * chunk - horizon  # steps past the horizon, masked out below
    step_keys = jnp.concatenate([step_keys, jnp.repeat(step_keys[-1:], padding, axis=0)], axis=0)
    step_keys = step_keys.reshape((chunks, chunk) + step_keys.shape[1:])
    batch = state.obs.shape[:1]

    def step(carry: tuple, step_key: jax.Array) -> tuple[tuple, None]:
        state, alive, total, length, score, t = carry
        next_state, record = _transition(env, act_fn, params, state, step_key)
        counted = jnp.logical_and(alive, t < horizon)
        total = total + jnp.where(counted, record["rewards"], 0.0)
        length = length + counted.astype(jnp.float32)
        score = jnp.where(counted, record["metrics"]["task_score"].astype(jnp.float32), score)
        alive = jnp.logical_and(counted, ~next_state.done)
        return (next_state, alive, total, length, score, t + 1), None

    def run_chunk(loop: tuple) -> tuple:
        carry, index = loop
        carry, _ = jax.lax.scan(step, carry, jax.lax.dynamic_index_in_dim(step_keys, index, keepdims=False))
        return carry, index + 1

    def any_running(loop: tuple) -> jax.Array:
        carry, index = loop
        return jnp.logical_and(index < chunks, jnp.any(carry[1]))

    zeros = jnp.zeros(batch, jnp.float32)
    carry = (state, jnp.ones(batch, bool), zeros, zeros, zeros, jnp.asarray(0, jnp.int32))
    (_, _, total, length, score, _), _ = jax.lax.while_loop(any_running, run_chunk, (carry, jnp.asarray(0, jnp.int32)))
    return {"return": total, "length": length, "task_score": score}


def flatten_samples(x: jax.Array) -> jax.Array:
    """``[T, B, ...] -> [B * T, ...]``, env-major: row ``b * T + t`` is env ``b``'s step ``t``.

    The one way jaxpg flattens a time-major batch (a ``Trajectory`` field, advantages, value
    targets ...) into training rows: every algorithm's ``Batch`` is built with it, so an array
    flattened any other way (``x.reshape((-1,) + x.shape[2:])`` is time-major) has the same shape
    but puts its values next to the wrong observations and actions, with no error.

    Env-major, because each device's envs then stay one contiguous block of rows: a batch whose
    env axis is sharded over devices stays sharded after flattening, and the learning side
    (gradients, Fisher-vector products, value fit) runs on each device's own samples. Time-major
    rows would interleave the devices' envs and make XLA gather the whole batch everywhere.
    """
    return jnp.swapaxes(x, 0, 1).reshape((-1,) + x.shape[2:])


def with_initial(first: dict[str, jax.Array], extras: dict[str, jax.Array]) -> dict[str, jax.Array]:
    """``extras [T, B, ...]`` (what ``record_fn`` read after every step) with ``first [B, ...]``
    (the same read from the initial states) in front: ``[T + 1, B, ...]``, every state of an
    episodic rollout from its reset on."""
    return {k: jnp.concatenate([first[k][None], extras[k]], axis=0) for k in extras}


def last_valid(traj: Trajectory, x: jax.Array) -> jax.Array:
    """``x [T, B]`` at each env's last valid step (where its episode ended, or the last step of
    one still running): ``[B]``. For episodic rollouts, whose ``valid`` is 1 up to that step."""
    last = jnp.maximum(jnp.sum(traj.valid, axis=0).astype(jnp.int32) - 1, 0)
    return jnp.take_along_axis(x, last[None, :], axis=0)[0]


def episode_summary(traj: Trajectory) -> dict[str, jax.Array]:
    """Means over the episodes that ended inside ``traj`` (NaN where none did).

    Needs the ``EpisodeStats`` wrapper. Returns ``episode_return``, ``episode_length``,
    ``episode_task_score`` and ``episodes`` (how many ended), all scalars.
    """
    ended = traj.metrics["episode_done"] * traj.valid
    count = jnp.sum(ended)

    def mean(x: jax.Array) -> jax.Array:
        return jnp.where(count > 0, jnp.sum(x * ended) / jnp.maximum(count, 1.0), jnp.nan)

    return {
        "episode_return": mean(traj.metrics["episode_return"]),
        "episode_length": mean(traj.metrics["episode_length"]),
        "episode_task_score": mean(traj.metrics["episode_task_score"]),
        "episodes": count,
    }
