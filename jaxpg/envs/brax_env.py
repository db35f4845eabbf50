"""jaxpg's tasks as Brax environments, for Brax's trainers (``pip install 'jaxpg[brax]'``).

    env = jaxpg.envs.brax_env.as_brax_env("ant")          # fast MJX physics, actions in [-1, 1]
    with brax_jax_shim():                                  # jaxpg.envs.brax_compat
        make_policy, params, _ = brax.training.agents.ppo.train.train(
            environment=env, num_timesteps=..., episode_length=1000, bootstrap_on_timeout=True, ...)

``JaxpgBraxEnv`` implements ``brax.envs.base.Env`` on one environment; Brax's own wrappers
(``VmapWrapper``, ``EpisodeWrapper``, ``AutoResetWrapper``, ``EvalWrapper``) batch it and reset it.
Its ``State.pipeline_state`` is the whole jaxpg ``State`` (physics data, step counter, reset key).

Time limit. With ``time_limit=True`` (the default) the env ends an episode at the task's own limit
(``max_episode_steps``, Gymnasium's) with ``done = 1`` and ``info["time_out"] = 1``, and at a
termination with ``done = 1`` and ``time_out = 0``: ``time_out`` is Gymnasium's ``truncated``, the
flag Brax's ``bootstrap_on_timeout=True`` reads. With ``time_limit=False`` the env never ends an
episode for time (as Brax's own envs) and ``time_out`` stays 0: Brax's ``EpisodeWrapper`` then ends
episodes at ``episode_length`` and marks them in ``info["truncation"]``.

Resets. Brax's ``AutoResetWrapper`` keeps the first state of each env slot and puts it back at every
episode end, so slot ``i`` replays one initial state for the whole run, where Gymnasium draws new
reset noise at every reset. ``wrap_for_training`` (pass it as ``wrap_env_fn``) is Brax's wrapper
stack with ``FreshResetWrapper`` in that place: a new episode starts from a fresh ``reset``.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from brax.envs import base as brax_base
from brax.envs.wrappers import training as brax_training

from jaxpg import envs as envs_lib
from jaxpg.envs.base import Env
from jaxpg.envs.wrappers import ClipAction, RescaleAction


class JaxpgBraxEnv(brax_base.Env):
    """A jaxpg ``Env`` (one environment) behind Brax's ``Env`` interface.

    ``reset(rng [2]) -> State`` and ``step(state, action [action_size]) -> State``, ``State`` being
    Brax's: ``obs [observation_size]`` float32, ``reward []`` and ``done []`` float32, ``metrics``
    (the task's per-step terms, e.g. ``reward_forward``, ``task_score``), ``info`` (``time_out``
    ``[]`` float32) and ``pipeline_state`` (the jaxpg ``State``).
    """

    def __init__(self, task: Env, time_limit: bool = True):
        if task.discrete:
            raise ValueError(f"Brax's trainers need continuous actions; {task.name!r} has discrete ones")
        self.task = task
        self.time_limit = time_limit

    @property
    def observation_size(self) -> int:
        return int(self.task.observation_size)

    @property
    def action_size(self) -> int:
        return int(self.task.action_size)

    @property
    def backend(self) -> str:
        """``"mjx"`` for an MJX task (``"mjx-warp"`` on MuJoCo Warp), ``"jax"`` for a pure-JAX one."""
        impl = getattr(self.task.unwrapped, "impl", None)
        return {None: "jax", "jax": "mjx"}.get(impl, f"mjx-{impl}")

    @property
    def dt(self) -> float:
        return float(self.task.dt)

    @property
    def max_episode_steps(self) -> int:
        return int(self.task.max_episode_steps)

    def reset(self, rng: jax.Array) -> brax_base.State:
        inner = self.task.reset(rng)
        zero = jnp.zeros((), jnp.float32)
        return brax_base.State(
            pipeline_state=inner,
            obs=inner.obs,
            reward=zero,
            done=zero,
            metrics=_float_metrics(inner.metrics),
            info={"time_out": zero},
        )

    def step(self, state: brax_base.State, action: jax.Array) -> brax_base.State:
        inner = self.task.step(state.pipeline_state, action)
        ended = inner.done if self.time_limit else inner.terminated
        time_out = inner.truncated if self.time_limit else jnp.zeros((), bool)
        return state.replace(
            pipeline_state=inner,
            obs=inner.obs,
            reward=inner.reward,
            done=ended.astype(jnp.float32),
            metrics={**state.metrics, **_float_metrics(inner.metrics)},  # keeps what wrappers added
            info={**state.info, "time_out": time_out.astype(jnp.float32)},
        )

    def __repr__(self) -> str:
        return f"JaxpgBraxEnv({self.task!r}, time_limit={self.time_limit})"


def _float_metrics(metrics: dict[str, jax.Array]) -> dict[str, jax.Array]:
    """The task's metrics as float32 scalars (Brax's ``EpisodeWrapper`` sums them over an episode)."""
    return {name: jnp.asarray(value, jnp.float32) for name, value in metrics.items()}


def as_brax_env(
    task: str | Env, time_limit: bool = True, action_scaling: bool = True, **task_kwargs: Any
) -> JaxpgBraxEnv:
    """Task ``task`` (a ``jaxpg.envs`` name, made with ``task_kwargs``, or a bare task) as a Brax env.

    ``action_scaling``: the env takes actions in ``[-1, 1]``, as every Brax env and Brax's tanh
    policies do, mapped onto the task's range (``RescaleAction``; Humanoid's is ``[-0.4, 0.4]``);
    they are clipped to that range first (``ClipAction``). ``time_limit``: see the module's
    docstring. ``ValueError`` for a discrete task or an unknown name.
    """
    bare = envs_lib.make_task(task, **task_kwargs) if isinstance(task, str) else task
    return JaxpgBraxEnv(ClipAction(RescaleAction(bare) if action_scaling else bare), time_limit=time_limit)


def _split_each(keys: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Two new keys from each raw key of ``keys [..., 2]`` (``uint32``, as Brax passes them)."""
    split = jax.random.split
    for _ in range(keys.ndim - 1):
        split = jax.vmap(split)
    pairs = split(keys)  # [..., 2, 2]
    return pairs[..., 0, :], pairs[..., 1, :]


class FreshResetWrapper(brax_base.Wrapper):
    """Brax's ``AutoResetWrapper`` with Gymnasium's resets: an env that is done continues from a new
    ``reset`` (fresh reset noise, from a key of its own) rather than from its cached first state.

    Sits where ``AutoResetWrapper`` sits (outermost, over the batch); keeps ``info["reset_rng"]``
    (one raw key ``[2]`` per env). ``info["steps"]`` restarts as in Brax's wrapper. Every step pays
    for one ``reset`` of the batch, whose result is kept where an episode ended.
    """

    def reset(self, rng: jax.Array) -> brax_base.State:
        rng, reset_rng = _split_each(rng)
        state = self.env.reset(rng)
        state.info["reset_rng"] = reset_rng
        return state

    def step(self, state: brax_base.State, action: jax.Array) -> brax_base.State:
        if "steps" in state.info:
            state.info["steps"] = jnp.where(state.done, jnp.zeros_like(state.info["steps"]), state.info["steps"])
        reset_rng, rng = _split_each(state.info["reset_rng"])
        state = self.env.step(state.replace(done=jnp.zeros_like(state.done)), action)
        fresh = self.env.reset(rng)

        def where_done(new: jax.Array, old: jax.Array) -> jax.Array:
            done = jnp.reshape(state.done, state.done.shape + (1,) * (old.ndim - state.done.ndim))
            return jnp.where(done, new, old)

        pipeline_state = jax.tree.map(where_done, fresh.pipeline_state, state.pipeline_state)
        obs = jax.tree.map(where_done, fresh.obs, state.obs)
        state.info["reset_rng"] = reset_rng
        return state.replace(pipeline_state=pipeline_state, obs=obs)


def wrap_for_training(
    env: brax_base.Env,
    episode_length: int = 1000,
    action_repeat: int = 1,
    randomization_fn: Any = None,
) -> brax_base.Wrapper:
    """Brax's ``envs.training.wrap`` (vmap, then ``EpisodeWrapper``) topped with
    ``FreshResetWrapper`` in place of ``AutoResetWrapper``: pass it to Brax's trainers as
    ``wrap_env_fn``. Domain randomization (``randomization_fn``) needs a Brax ``System``, which a
    jaxpg task has not: ``ValueError``."""
    if randomization_fn is not None:
        raise ValueError("wrap_for_training: domain randomization needs a Brax System; jaxpg tasks have none")
    env = brax_training.VmapWrapper(env)
    env = brax_training.EpisodeWrapper(env, episode_length, action_repeat)
    return FreshResetWrapper(env)
