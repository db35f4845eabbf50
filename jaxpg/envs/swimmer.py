"""Swimmer with the semantics of Gymnasium's ``Swimmer-v5``.

The swimmer's position ``qpos[:2]`` is that of the front segment's frame (two slider joints; the frame
sits at the middle segment's centre). Observation ``[8]``: ``qpos[2:]`` (the front segment's angle
and the two joint angles) then ``qvel`` (5 velocities), unclipped. Action ``[2]`` in ``[-1, 1]``:
torques on the two joints (gear 150). Reward: forward velocity ``(x_after - x_before) / dt`` -
1e-4 * |action|^2. The episode never terminates; it ends at the 1000-step limit. Reset noise:
uniform +-0.1 on qpos and qvel. Frame skip 4 (dt 0.04 s). The swimmer moves through MuJoCo's
viscous fluid model (``density``, ``viscosity`` of the model's options), which MJX's JAX
implementation computes as MuJoCo does.

Metrics: Gymnasium's ``info`` terms ``reward_forward``, ``reward_ctrl`` (negative), ``x_position``,
``y_position``, ``distance_from_origin``, ``x_velocity`` and ``y_velocity``; the task score is the
forward distance ``x_position`` (``qpos[0]``). No deviation from Gymnasium's task.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv, planar_position_metrics


class Swimmer(MjxEnv):
    """MJX Swimmer; see the module docstring for the task definition."""

    task_score_name = "forward_distance"

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        forward_reward_weight: float = 1.0,
        ctrl_cost_weight: float = 1e-4,
        reset_noise_scale: float = 0.1,
        exclude_current_positions_from_observation: bool = True,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "swimmer.xml",
            frame_skip=4,
            fidelity=fidelity,
            impl=impl,
            max_episode_steps=max_episode_steps,
            **mjx_kwargs,
        )
        self.skipped_qpos = 2 if exclude_current_positions_from_observation else 0  # qpos[:2] is x-y
        self.observation_size = self.nq - self.skipped_qpos + self.nv
        self.action_size = self.mj_model.nu
        self.forward_reward_weight = forward_reward_weight
        self.ctrl_cost_weight = ctrl_cost_weight
        self.reset_noise_scale = reset_noise_scale

    def observation(self, qpos: jax.Array, qvel: jax.Array) -> jax.Array:
        """``[observation_size]`` observation (8 by default) from ``qpos [5]`` and ``qvel [5]``."""
        return jnp.concatenate([qpos[self.skipped_qpos :], qvel])

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        kq, kv = jax.random.split(key)
        s = self.reset_noise_scale
        qpos = self.init_qpos + jax.random.uniform(kq, (self.nq,), minval=-s, maxval=s)
        qvel = self.init_qvel + jax.random.uniform(kv, (self.nv,), minval=-s, maxval=s)
        return self.start_state(qpos, qvel)

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` at ``qpos [nq]``, ``qvel [nv]`` (``MjxEnv.start_state``)."""
        data = self.physics_state(qpos, qvel)
        zero = jnp.zeros((), data.qpos.dtype)  # the dtype of the step's metrics: one compiled step
        metrics = {
            "reward_forward": zero,
            "reward_ctrl": zero,
            "x_velocity": zero,
            "y_velocity": zero,
            **planar_position_metrics(qpos),
        }
        return data, self.observation(qpos, qvel), metrics

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        xy_before = state.data.qpos[:2]
        data = self.physics_step(state.data, action)
        xy_velocity = (data.qpos[:2] - xy_before) / self.dt
        forward = self.forward_reward_weight * xy_velocity[0]
        ctrl_cost = self.ctrl_cost_weight * jnp.sum(jnp.square(action))
        metrics = {
            "reward_forward": forward,
            "reward_ctrl": -ctrl_cost,
            "x_velocity": xy_velocity[0],
            "y_velocity": xy_velocity[1],
            **planar_position_metrics(data.qpos),
        }
        return data, self.observation(data.qpos, data.qvel), forward - ctrl_cost, jnp.zeros((), bool), metrics
