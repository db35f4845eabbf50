"""Wrappers around the functional env API: action clipping, episode statistics, automatic reset.

Each wrapper is itself an ``Env`` with pure ``reset``/``step`` on one environment. The usual stack,
built by ``jaxpg.envs.make``, is ``EpisodeStats(ClipAction(task))`` (with ``RescaleAction`` under
``ClipAction`` when asked for); the continuing sampler adds ``AutoReset`` on top.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.envs.base import Env, State, check_action, expand_like


class Wrapper(Env):
    """Forwards everything to ``env``; subclasses override ``reset`` and/or ``step``."""

    def __init__(self, env: Env):
        self.env = env

    def __getattr__(self, name: str) -> Any:
        if name == "env":  # not yet set: avoid infinite recursion during unpickling/copying
            raise AttributeError(name)
        return getattr(self.env, name)

    # `Env` gives these class-level defaults, which `__getattr__` would never see past.
    discrete = property(lambda self: self.env.discrete)
    task_score_name = property(lambda self: self.env.task_score_name)
    image_shape = property(lambda self: self.env.image_shape)
    action_low = property(lambda self: self.env.action_low)
    action_high = property(lambda self: self.env.action_high)
    name = property(lambda self: self.env.name)

    def _reset(self, key: jax.Array) -> Any:  # pragma: no cover - wrappers override reset
        raise NotImplementedError

    def _step(self, state: State, action: jax.Array) -> Any:  # pragma: no cover
        raise NotImplementedError

    def reset(self, key: jax.Array) -> State:
        return self.env.reset(key)

    def step(self, state: State, action: jax.Array) -> State:
        return self.env.step(state, action)

    def select_physics(self, pick_new: jax.Array, new: Any, old: Any) -> Any:
        return self.env.select_physics(pick_new, new, old)

    @property
    def unwrapped(self) -> Env:
        return self.env.unwrapped

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.env!r})"


class ClipAction(Wrapper):
    """Clips a continuous action ``[action_size]`` to ``[action_low, action_high]`` before the task.

    The task's control cost is then charged on the clipped action, as in Stable-Baselines3 and
    Brax. Discrete tasks pass through unchanged. The action's shape is checked first
    (``check_action``), so that a scalar is never broadcast to every actuator by bounds given per
    actuator; a NaN stays NaN and ends the episode as ``nonfinite``.
    """

    def step(self, state: State, action: jax.Array) -> State:
        action = check_action(self.env, action)
        if not self.env.discrete:
            action = jnp.clip(action, self.env.action_low, self.env.action_high)
        return self.env.step(state, action)


class RescaleAction(Wrapper):
    """Takes continuous actions in ``[-1, 1]`` and maps them linearly onto the task's
    ``[action_low, action_high]``: ``-1`` to ``action_low``, ``1`` to ``action_high``.

    A policy then acts in the same units on every task (Tianshou's ``action_scaling``,
    Gymnasium's ``RescaleAction(env, -1, 1)``): its initial noise and the size of its updates
    mean the same fraction of the range on Humanoid (``[-0.4, 0.4]``) as on Hopper. Put it under
    ``ClipAction``, which then clips to ``[-1, 1]``. ``ValueError`` for a discrete task.
    """

    action_low = property(lambda self: -1.0)
    action_high = property(lambda self: 1.0)

    def __init__(self, env: Env):
        if env.discrete:
            raise ValueError(f"RescaleAction needs continuous actions; {env.name!r} has discrete ones")
        super().__init__(env)

    def step(self, state: State, action: jax.Array) -> State:
        return self.env.step(state, unit_to_range(action, self.env.action_low, self.env.action_high))


def unit_to_range(action: jax.Array, low: float, high: float) -> jax.Array:
    """``action`` (any shape) mapped linearly from ``[-1, 1]`` onto ``[low, high]``."""
    return (high + low) / 2 + (high - low) / 2 * action


class EpisodeStats(Wrapper):
    """Keeps running episode return and length in ``info`` and reports them when an episode ends.

    Adds to ``metrics`` at every step (meaningful where ``done``):
      ``episode_return``: sum of rewards of the episode that just ended;
      ``episode_length``: its number of steps;
      ``episode_task_score``: the task's ``task_score`` at its last step;
      ``episode_done``: 1.0 where an episode ended at this step, else 0.0.
    Averages over ended episodes are ``sum(x * episode_done) / sum(episode_done)``.
    """

    def reset(self, key: jax.Array) -> State:
        state = self.env.reset(key)
        zero = jnp.zeros((), jnp.float32)
        info = {**state.info, "episode_return": zero, "episode_length": jnp.zeros((), jnp.int32)}
        metrics = {
            **state.metrics,
            "episode_return": zero,
            "episode_length": zero,
            "episode_task_score": zero,
            "episode_done": zero,
        }
        return state.replace(info=info, metrics=metrics)

    def step(self, state: State, action: jax.Array) -> State:
        state = self.env.step(state, action)
        done = state.done
        ep_return = state.info["episode_return"] + state.reward
        ep_length = state.info["episode_length"] + 1
        metrics = {
            **state.metrics,
            "episode_return": ep_return,
            "episode_length": ep_length.astype(jnp.float32),
            "episode_task_score": state.metrics["task_score"].astype(jnp.float32),
            "episode_done": done.astype(jnp.float32),
        }
        info = {
            **state.info,
            "episode_return": jnp.where(done, 0.0, ep_return),
            "episode_length": jnp.where(done, 0, ep_length),
        }
        return state.replace(info=info, metrics=metrics)


class AutoReset(Wrapper):
    """Starts a new episode (with a fresh key) as soon as one ends.

    The returned state at an episode end carries the *new* episode's first observation in ``obs``,
    while ``info["final_obs"]`` keeps the observation the ended episode finished in (equal to
    ``obs`` at all other steps): truncated episodes bootstrap their value from it.
    ``reward``, ``terminated``, ``truncated`` and ``metrics`` stay those of the step taken. The task
    selects the physics state (``Env.select_physics``): an MJX task takes only what its next step
    reads from the new episode's state.
    """

    def reset(self, key: jax.Array) -> State:
        state = self.env.reset(key)
        return state.replace(info={**state.info, "final_obs": state.obs})

    def step(self, state: State, action: jax.Array) -> State:
        inner = state.replace(info={k: v for k, v in state.info.items() if k != "final_obs"})
        stepped = self.env.step(inner, action)
        done = stepped.done
        fresh = self.env.reset(stepped.info["rng"])

        def pick(new: jax.Array, old: jax.Array) -> jax.Array:
            return jnp.where(expand_like(done, old), new, old)

        data = self.env.select_physics(done, fresh.data, stepped.data)
        obs = pick(fresh.obs, stepped.obs)
        info = jax.tree.map(pick, fresh.info, stepped.info)
        return stepped.replace(data=data, obs=obs, info={**info, "final_obs": stepped.obs})
