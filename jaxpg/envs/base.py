"""The functional environment API shared by every jaxpg task.

An environment is an object with two pure functions, ``reset(key) -> State`` and
``step(state, action) -> State``, in the convention of Brax and MuJoCo Playground. Both act on
*one* environment; batching is ``jax.vmap`` (see ``jaxpg.rollout``). Everything that changes over
time lives in ``State``; the env object itself only holds constants (the compiled MuJoCo model,
reward weights), so it can be closed over inside ``jit``.

Termination semantics follow Gymnasium v0.26+: ``terminated`` means the task itself ended (the
hopper fell, the pole tipped over) and the value of the next state is zero; ``truncated`` means
the time limit cut the episode short and the value of the final observation must be bootstrapped.
Here the two are exclusive: a step that both reaches the limit and ends the task is ``terminated``.
"""

from __future__ import annotations

import abc
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class State:
    """State of one environment (add a leading batch axis under ``vmap``).

    Attributes:
      data: the physics state: ``mjx.Data`` for MJX tasks, a small pytree for pure-JAX tasks.
      obs: ``[observation_size]`` float32 observation *after* the step.
      reward: ``[]`` float32 reward of the step that led here (0 after ``reset``).
      terminated: ``[]`` bool, the task ended (no bootstrapping past it).
      truncated: ``[]`` bool, the time limit ended the episode (bootstrap from ``obs``).
      metrics: per-step scalars (reward terms, ``eval_metric``, ``nonfinite``, ``physics_overflow``);
        same keys always.
      info: bookkeeping that wrappers thread through: ``step`` (int32 step count in the episode),
        ``rng`` (key for the next reset) and whatever wrappers add.
    """

    data: Any
    obs: jax.Array
    reward: jax.Array
    terminated: jax.Array
    truncated: jax.Array
    metrics: dict[str, jax.Array]
    info: dict[str, Any]

    @property
    def done(self) -> jax.Array:
        """``[]`` bool: the episode ended, by termination or by the time limit."""
        return jnp.logical_or(self.terminated, self.truncated)


class Env(abc.ABC):
    """Base class of jaxpg tasks.

    Subclasses implement ``_reset(key) -> (data, obs, metrics)`` and
    ``_step(state, action) -> (data, obs, reward, terminated, metrics)``; this class adds the step
    counter, the time limit and the non-finite guard, so that every task handles them the same way.

    Attributes that every task sets:
      observation_size: length of ``obs``.
      action_size: dimension of a continuous action, or number of choices when ``discrete``.
      discrete: actions are int32 scalars in ``[0, action_size)`` rather than float vectors.
      dt: simulated seconds per ``step``.
      max_episode_steps: time limit; reaching it sets ``truncated``.
      eval_metric_name: what ``metrics["eval_metric"]`` measures (e.g. ``"forward_distance"``).
    """

    observation_size: int
    action_size: int
    discrete: bool = False
    dt: float
    max_episode_steps: int
    eval_metric_name: str = "return"
    action_low: float = -1.0
    action_high: float = 1.0

    @abc.abstractmethod
    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """Sample an initial physics state; returns ``(data, obs, metrics)``."""

    @abc.abstractmethod
    def _step(
        self, state: State, action: jax.Array
    ) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict[str, jax.Array]]:
        """Advance the physics; returns ``(data, obs, reward, terminated, metrics)``."""

    def _physics_finite(self, data: Any) -> jax.Array:
        """``[]`` bool: the physics state holds no NaN or inf. Pure-JAX tasks check every leaf."""
        leaves = [jnp.all(jnp.isfinite(x)) for x in jax.tree.leaves(data) if jnp.issubdtype(x.dtype, jnp.floating)]
        return jnp.all(jnp.stack(leaves)) if leaves else jnp.array(True)

    def _physics_overflow(self, data: Any) -> jax.Array:
        """``[]`` float32: 1 when the simulator hit one of its limits in the last step (MuJoCo
        Warp's solver iterations or buffers); pure-JAX tasks never do."""
        del data
        return jnp.zeros((), jnp.float32)

    def reset(self, key: jax.Array) -> State:
        """Start an episode. ``key``: a PRNG key; returns the initial ``State`` (reward 0)."""
        key, reset_key = jax.random.split(key)
        data, obs, metrics = self._reset(reset_key)
        metrics = {**metrics, "nonfinite": jnp.zeros((), jnp.float32), "physics_overflow": jnp.zeros((), jnp.float32)}
        info = {"step": jnp.zeros((), jnp.int32), "rng": key}
        return State(
            data=data,
            obs=obs.astype(jnp.float32),
            reward=jnp.zeros((), jnp.float32),
            terminated=jnp.zeros((), bool),
            truncated=jnp.zeros((), bool),
            metrics=metrics,
            info=info,
        )

    def step(self, state: State, action: jax.Array) -> State:
        """Advance one env step (``frame_skip`` physics steps for MJX tasks).

        A non-finite physics state, observation or reward ends the episode as ``terminated``
        with a zero reward and a zeroed observation, and counts 1 in ``metrics["nonfinite"]``,
        so that a diverging simulation never poisons the batch statistics.
        """
        data, obs, reward, terminated, metrics = self._step(state, action)
        finite = self._physics_finite(data) & jnp.all(jnp.isfinite(obs)) & jnp.isfinite(reward)
        obs = jnp.where(finite, obs, 0.0).astype(jnp.float32)
        reward = jnp.where(finite, reward, 0.0).astype(jnp.float32)
        terminated = jnp.logical_or(terminated, ~finite)
        steps = state.info["step"] + 1
        truncated = jnp.logical_and(steps >= self.max_episode_steps, ~terminated)
        metrics = {
            **metrics,
            "nonfinite": (~finite).astype(jnp.float32),
            "physics_overflow": self._physics_overflow(data),
        }
        return state.replace(
            data=data,
            obs=obs,
            reward=reward,
            terminated=terminated,
            truncated=truncated,
            metrics=metrics,
            info={**state.info, "step": steps},
        )

    @property
    def unwrapped(self) -> Env:
        """The task under all wrappers."""
        return self

    def __repr__(self) -> str:
        return f"{type(self).__name__}(obs={self.observation_size}, act={self.action_size})"
