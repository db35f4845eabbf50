"""Hopper with the semantics of Gymnasium's ``Hopper-v5``.

Observation ``[11]``: ``qpos[1:]`` (torso height, torso angle, thigh, leg, foot angles) then
``clip(qvel, -10, 10)`` (6 velocities). Action ``[3]`` in ``[-1, 1]``: torques on thigh, leg, foot
(gear 200). Reward: forward velocity of the torso + 1 while healthy - 1e-3 * |action|^2.
Healthy: ``z > 0.7``, ``|angle| < 0.2`` and every entry of ``(qpos, qvel)[2:]`` inside (-100, 100);
an unhealthy state terminates the episode (unless ``terminate_when_unhealthy=False``; the ranges
are Gymnasium's keywords too). Reset noise: uniform +-5e-3 on qpos and qvel.
``exclude_current_positions_from_observation=False`` observes ``qpos`` whole (x first), as in
Gymnasium.
Frame skip 4 (dt 0.008 s), 1000-step limit. The task score is the forward distance ``qpos[0]``.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv


class Hopper(MjxEnv):
    """MJX Hopper; see the module docstring for the task definition."""

    task_score_name = "forward_distance"

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        forward_reward_weight: float = 1.0,
        ctrl_cost_weight: float = 1e-3,
        healthy_reward: float = 1.0,
        terminate_when_unhealthy: bool = True,
        healthy_state_range: tuple[float, float] = (-100.0, 100.0),
        healthy_z_range: tuple[float, float] = (0.7, float("inf")),
        healthy_angle_range: tuple[float, float] = (-0.2, 0.2),
        reset_noise_scale: float = 5e-3,
        exclude_current_positions_from_observation: bool = True,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "hopper.xml",
            frame_skip=4,
            fidelity=fidelity,
            impl=impl,
            max_episode_steps=max_episode_steps,
            **mjx_kwargs,
        )
        self.skipped_qpos = 1 if exclude_current_positions_from_observation else 0
        self.observation_size = self.nq - self.skipped_qpos + self.nv
        self.action_size = self.mj_model.nu
        self.forward_reward_weight = forward_reward_weight
        self.ctrl_cost_weight = ctrl_cost_weight
        self.healthy_reward = healthy_reward
        self.terminate_when_unhealthy = terminate_when_unhealthy
        self.healthy_state_range = healthy_state_range
        self.healthy_z_range = healthy_z_range
        self.healthy_angle_range = healthy_angle_range
        self.reset_noise_scale = reset_noise_scale

    def observation(self, qpos: jax.Array, qvel: jax.Array) -> jax.Array:
        """``[observation_size]`` observation (11 by default) from ``qpos [6]`` and ``qvel [6]``."""
        return jnp.concatenate([qpos[self.skipped_qpos :], jnp.clip(qvel, -10.0, 10.0)])

    def is_healthy(self, qpos: jax.Array, qvel: jax.Array) -> jax.Array:
        """``[]`` bool: the hopper is upright, high enough and its state bounded (each inside its
        open healthy range)."""
        z, angle = qpos[1], qpos[2]
        state = jnp.concatenate([qpos, qvel])[2:]
        (state_min, state_max), (z_min, z_max) = self.healthy_state_range, self.healthy_z_range
        angle_min, angle_max = self.healthy_angle_range
        bounded = jnp.all((state_min < state) & (state < state_max))
        return bounded & (z_min < z) & (z < z_max) & (angle_min < angle) & (angle < angle_max)

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
            "reward_survive": zero,
            "x_position": qpos[0],
            "x_velocity": zero,
            "z_distance_from_origin": qpos[1] - self.init_qpos[1],
            "task_score": qpos[0],
        }
        return data, self.observation(qpos, qvel), metrics

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        x_before = state.data.qpos[0]
        data = self.physics_step(state.data, action)
        x_velocity = (data.qpos[0] - x_before) / self.dt
        healthy = self.is_healthy(data.qpos, data.qvel)
        forward = self.forward_reward_weight * x_velocity
        survive = self.healthy_reward * healthy.astype(data.qpos.dtype)
        ctrl_cost = self.ctrl_cost_weight * jnp.sum(jnp.square(action))
        reward = forward + survive - ctrl_cost
        metrics = {
            "reward_forward": forward,
            "reward_ctrl": -ctrl_cost,
            "reward_survive": survive,
            "x_position": data.qpos[0],
            "x_velocity": x_velocity,
            "z_distance_from_origin": data.qpos[1] - self.init_qpos[1],
            "task_score": data.qpos[0],
        }
        terminated = ~healthy if self.terminate_when_unhealthy else jnp.zeros_like(healthy)
        return data, self.observation(data.qpos, data.qvel), reward, terminated, metrics
