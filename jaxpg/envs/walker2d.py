"""Walker2d with the semantics of Gymnasium's ``Walker2d-v5``.

Observation ``[17]``: ``qpos[1:]`` (torso height, torso angle, the six joint angles) then
``clip(qvel, -10, 10)`` (9 velocities). Action ``[6]`` in ``[-1, 1]``: torques on the right thigh,
leg, foot and the left thigh, leg, foot (gear 100). Reward: forward velocity of the torso
``(x_after - x_before) / dt`` + 1 while healthy - 1e-3 * |action|^2. Healthy: torso height
``0.8 < z < 2`` and angle ``-1 < angle < 1`` (v5 checks no velocity bound, unlike Hopper); an
unhealthy state terminates the episode (unless ``terminate_when_unhealthy=False``), with no survive
reward on that step. Reset noise: uniform +-5e-3 on qpos and qvel. Frame skip 4 (dt 0.008 s),
1000-step limit. ``exclude_current_positions_from_observation=False`` observes ``qpos`` whole.

Metrics: Gymnasium's ``info`` terms ``reward_forward``, ``reward_ctrl`` (negative),
``reward_survive``, ``x_position``, ``x_velocity`` and ``z_distance_from_origin`` (torso height
above its initial 1.25); the task score is the forward distance ``x_position`` (``qpos[0]``).
No deviation from Gymnasium's task.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv


class Walker2d(MjxEnv):
    """MJX Walker2d; see the module docstring for the task definition."""

    task_score_name = "forward_distance"

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        forward_reward_weight: float = 1.0,
        ctrl_cost_weight: float = 1e-3,
        healthy_reward: float = 1.0,
        healthy_z_range: tuple[float, float] = (0.8, 2.0),
        healthy_angle_range: tuple[float, float] = (-1.0, 1.0),
        terminate_when_unhealthy: bool = True,
        reset_noise_scale: float = 5e-3,
        exclude_current_positions_from_observation: bool = True,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "walker2d.xml",
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
        self.healthy_z_range = healthy_z_range
        self.healthy_angle_range = healthy_angle_range
        self.terminate_when_unhealthy = terminate_when_unhealthy
        self.reset_noise_scale = reset_noise_scale
        self.init_z = float(self.mj_model.qpos0[1])

    def observation(self, qpos: jax.Array, qvel: jax.Array) -> jax.Array:
        """``[observation_size]`` observation (17 by default) from ``qpos [9]`` and ``qvel [9]``."""
        return jnp.concatenate([qpos[self.skipped_qpos :], jnp.clip(qvel, -10.0, 10.0)])

    def is_healthy(self, qpos: jax.Array) -> jax.Array:
        """``[]`` bool: the torso's height and angle are inside their (open) healthy ranges."""
        z, angle = qpos[1], qpos[2]
        (z_min, z_max), (angle_min, angle_max) = self.healthy_z_range, self.healthy_angle_range
        return (z_min < z) & (z < z_max) & (angle_min < angle) & (angle < angle_max)

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
            "z_distance_from_origin": qpos[1] - self.init_z,
            "task_score": qpos[0],
        }
        return data, self.observation(qpos, qvel), metrics

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        x_before = state.data.qpos[0]
        data = self.physics_step(state.data, action)
        x_velocity = (data.qpos[0] - x_before) / self.dt
        healthy = self.is_healthy(data.qpos)
        forward = self.forward_reward_weight * x_velocity
        survive = self.healthy_reward * healthy.astype(x_velocity.dtype)
        ctrl_cost = self.ctrl_cost_weight * jnp.sum(jnp.square(action))
        metrics = {
            "reward_forward": forward,
            "reward_ctrl": -ctrl_cost,
            "reward_survive": survive,
            "x_position": data.qpos[0],
            "x_velocity": x_velocity,
            "z_distance_from_origin": data.qpos[1] - self.init_z,
            "task_score": data.qpos[0],
        }
        reward = forward + survive - ctrl_cost
        terminated = ~healthy if self.terminate_when_unhealthy else jnp.zeros_like(healthy)
        return data, self.observation(data.qpos, data.qvel), reward, terminated, metrics
