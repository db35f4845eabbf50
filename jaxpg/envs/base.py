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

Actions are checked when ``step`` is traced (``check_action``): a continuous task takes a float
vector ``[action_size]``, a discrete one an integer scalar; any other shape, or a float action for a
discrete task, raises ``ValueError`` at once (under ``jit`` and ``vmap`` too, where the check sees
the shape of one environment's action), so nothing is broadcast silently. A discrete action out of
``[0, action_size)`` cannot be caught at trace time: ``step`` then does not take the step (the
physics state stays as it was), ends the episode as ``terminated`` with reward 0 and a zeroed
observation, and counts 1 in ``metrics["invalid_action"]``.
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
      metrics: per-step scalars (reward terms, ``task_score``, ``nonfinite``, ``invalid_action``,
        ``physics_overflow``); same keys always.
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


def expand_like(pick: jax.Array, leaf: jax.Array) -> jax.Array:
    """``pick`` with trailing axes of size 1, to broadcast against ``leaf`` (batch axes first)."""
    return jnp.reshape(pick, jnp.shape(pick) + (1,) * (jnp.ndim(leaf) - jnp.ndim(pick)))


def _snake_case(name: str) -> str:
    """``"InvertedPendulum"`` -> ``"inverted_pendulum"``."""
    return "".join("_" + c.lower() if c.isupper() and i else c.lower() for i, c in enumerate(name))


def _shape(shape: tuple[int, ...]) -> str:
    """``(3,)``, ``()``: a shape as Python prints a tuple."""
    return str(tuple(shape))


def check_action(env: Env, action: Any) -> jax.Array:
    """``action`` as an array, after checking its shape and dtype against ``env`` (at trace time).

    A continuous task wants ``[action_size]`` (any real dtype), a discrete one an integer scalar
    ``[]``. The check reads only ``action.shape`` and ``action.dtype``, which are static under
    ``jit``, so it costs nothing at run time; under ``vmap`` it sees one environment's action.

    Raises:
      ValueError: naming the expected and the given shape (or dtype), e.g. ``"hopper expects an
        action of shape (3,), got (2,)"``.
    """
    action = jnp.asarray(action)
    if env.discrete:
        expected = f"{env.name} expects an integer action of shape () (an index in [0, {env.action_size}))"
        if action.shape != ():
            raise ValueError(f"{expected}, got shape {_shape(action.shape)}{_batch_hint(action.shape, ())}")
        if not jnp.issubdtype(action.dtype, jnp.integer):
            raise ValueError(f"{expected}, got dtype {action.dtype}")
        return action
    expected_shape = (env.action_size,)
    if action.shape != expected_shape:
        hint = _batch_hint(action.shape, expected_shape)
        expected = f"{env.name} expects an action of shape {_shape(expected_shape)}"
        raise ValueError(f"{expected}, got {_shape(action.shape)}{hint}")
    if not (jnp.issubdtype(action.dtype, jnp.floating) or jnp.issubdtype(action.dtype, jnp.integer)):
        raise ValueError(f"{env.name} expects a real-valued action, got dtype {action.dtype}")
    return action


def _batch_hint(given: tuple[int, ...], expected: tuple[int, ...]) -> str:
    """A note for a batch of actions given to ``step``, which acts on one environment."""
    if expected == () and tuple(given) == (1,):
        return ""
    if len(given) > len(expected) and tuple(given[len(given) - len(expected) :]) == expected:
        return " (step acts on one environment: use jax.vmap(env.step) for a batch)"
    return ""


class Env(abc.ABC):
    """Base class of jaxpg tasks.

    Subclasses implement ``_reset(key) -> (data, obs, metrics)`` and
    ``_step(state, action) -> (data, obs, reward, terminated, metrics)``; this class adds the step
    counter, the time limit and the non-finite guard, so that every task handles them the same way.

    Attributes that every task sets:
      observation_size: length of ``obs``.
      action_size: dimension of a continuous action, or number of choices when ``discrete``.
      discrete: actions are integer scalars in ``[0, action_size)`` rather than float vectors.
      dt: simulated seconds per ``step``.
      max_episode_steps: time limit; reaching it sets ``truncated``.
      task_score_name: what ``metrics["task_score"]`` measures: the task's own score of an episode
        so far, beside its return (e.g. ``"forward_distance"``; ``"return"`` where they coincide).
      image_shape: ``(height, width, channels)`` when ``obs`` is a flattened image (row-major,
        channels last), which a convolutional network may read; ``None`` otherwise.
    """

    observation_size: int
    action_size: int
    discrete: bool = False
    dt: float
    max_episode_steps: int
    task_score_name: str = "return"
    image_shape: tuple[int, int, int] | None = None
    action_low: float = -1.0
    action_high: float = 1.0

    @property
    def name(self) -> str:
        """The task's name in messages: its class name in snake case (tasks may set ``name``)."""
        return _snake_case(type(self).__name__)

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
        zero = jnp.zeros((), jnp.float32)
        metrics = {**metrics, "nonfinite": zero, "invalid_action": zero, "physics_overflow": zero}
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

        ``action``: ``[action_size]`` real for a continuous task, an integer scalar ``[]`` for a
        discrete one; any other shape or a float action for a discrete task raises ``ValueError``
        when traced (``check_action``).

        A non-finite physics state, observation or reward ends the episode as ``terminated``
        with a zero reward and a zeroed observation, and counts 1 in ``metrics["nonfinite"]``,
        so that a diverging simulation never poisons the batch statistics. A discrete action
        outside ``[0, action_size)`` is not taken: the physics state stays that before the step,
        and the step ends the episode the same way (``terminated``, reward 0, zeroed observation),
        counting 1 in ``metrics["invalid_action"]`` instead.
        """
        action = check_action(self, action)
        valid = self._valid_action(action)
        if self.discrete:
            action = jnp.clip(action, 0, self.action_size - 1)  # any valid index; the step is undone below
        data, obs, reward, terminated, metrics = self._step(state, action)
        if self.discrete:
            data = jax.tree.map(lambda new, old: jnp.where(valid, new, old), data, state.data)
        finite = self._physics_finite(data) & jnp.all(jnp.isfinite(obs)) & jnp.isfinite(reward)
        ok = finite & valid
        obs = jnp.where(ok, obs, 0.0).astype(jnp.float32)
        reward = jnp.where(ok, reward, 0.0).astype(jnp.float32)
        terminated = jnp.logical_or(terminated, ~ok)
        steps = state.info["step"] + 1
        truncated = jnp.logical_and(steps >= self.max_episode_steps, ~terminated)
        metrics = {
            **metrics,
            "nonfinite": (valid & ~finite).astype(jnp.float32),
            "invalid_action": (~valid).astype(jnp.float32),
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

    def select_physics(self, pick_new: jax.Array, new: Any, old: Any) -> Any:
        """The physics state ``new`` where ``pick_new`` is true, else ``old``: how an automatic reset
        puts a new episode's state in place of the one that ended.

        ``pick_new``: a ``[]`` bool for one env (inside ``vmap``) or the batch's leading shape of
        the physics state's leaves. This default selects every leaf; MJX tasks select less
        (``MjxEnv.select_physics``).
        """
        return jax.tree.map(lambda n, o: jnp.where(expand_like(pick_new, o), n, o), new, old)

    def _valid_action(self, action: jax.Array) -> jax.Array:
        """``[]`` bool: a discrete ``action`` is in ``[0, action_size)``; continuous ones always are
        (their range is ``ClipAction``'s business, and a NaN shows up as ``nonfinite``)."""
        if not self.discrete:
            return jnp.ones((), bool)
        return (action >= 0) & (action < self.action_size)

    @property
    def unwrapped(self) -> Env:
        """The task under all wrappers."""
        return self

    def __repr__(self) -> str:
        return f"{type(self).__name__}(obs={self.observation_size}, act={self.action_size})"
