"""Reacher with the semantics of Gymnasium's ``Reacher-v5``.

Observation ``[10]``: ``cos`` then ``sin`` of the two arm angles ``qpos[:2]``, the target's position
``qpos[2:]``, the arm's angular velocities ``qvel[:2]`` and the horizontal offset ``(fingertip -
target)[:2]`` of the two bodies' frames. Action ``[2]`` in ``[-1, 1]``: torques on the shoulder and
the elbow (gear 200). Reward: ``-|fingertip - target|`` (``reward_dist``, the 3-d distance) ``-
|action|^2`` (``reward_ctrl``), of the state after the step (as v5; v4 read it before). The
episode never terminates; it ends at the 50-step limit. Reset: the arm angles uniform +-0.1 around
the initial pose and their velocities uniform +-5e-3; the target uniform in the disk of radius 0.2
around the origin (drawn as Gymnasium does: uniform in the square of side 0.4 until a point falls
inside), at rest. Frame skip 2 (dt 0.02 s).

The bodies' positions are those MuJoCo leaves in ``data.xpos`` after the step, as Gymnasium reads
them (``get_body_com``): ``mj_step`` and ``mjx.step`` run the forward pass before integrating, so
with RK4 they belong to its last Runge-Kutta stage, with Euler to the start of the last physics step.

Metrics: Gymnasium's ``info`` terms ``reward_dist`` and ``reward_ctrl``; the task score is the
distance from fingertip to target (``-reward_dist``; lower is better), at the episode's end the
task's measure of success. No deviation from Gymnasium's task.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import mujoco

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv


class Reacher(MjxEnv):
    """MJX Reacher; see the module docstring for the task definition."""

    task_score_name = "distance_to_target"

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 50,
        reward_dist_weight: float = 1.0,
        reward_control_weight: float = 1.0,
        arm_noise_scale: float = 0.1,
        arm_velocity_noise_scale: float = 5e-3,
        target_radius: float = 0.2,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "reacher.xml",
            frame_skip=2,
            fidelity=fidelity,
            impl=impl,
            max_episode_steps=max_episode_steps,
            **mjx_kwargs,
        )
        self.observation_size = 10
        self.action_size = self.mj_model.nu
        self.reward_dist_weight = reward_dist_weight
        self.reward_control_weight = reward_control_weight
        self.arm_noise_scale = arm_noise_scale
        self.arm_velocity_noise_scale = arm_velocity_noise_scale
        self.target_radius = target_radius
        self.fingertip_body = mujoco.mj_name2id(self.mj_model, mujoco.mjtObj.mjOBJ_BODY, "fingertip")
        self.target_body = mujoco.mj_name2id(self.mj_model, mujoco.mjtObj.mjOBJ_BODY, "target")

    def offset(self, data: Any) -> jax.Array:
        """``[3]`` fingertip minus target position, from ``data.xpos``."""
        return data.xpos[self.fingertip_body] - data.xpos[self.target_body]

    def observation(self, data: Any) -> jax.Array:
        """``[10]`` observation from an ``mjx.Data`` whose body positions are up to date."""
        angles = data.qpos[:2]
        return jnp.concatenate([jnp.cos(angles), jnp.sin(angles), data.qpos[2:], data.qvel[:2], self.offset(data)[:2]])

    def sample_target(self, key: jax.Array, draws: int = 32) -> jax.Array:
        """``[2]`` target position, uniform in the open disk of radius ``target_radius``: the first of
        ``draws`` uniform draws in the enclosing square that falls inside (each does with probability
        pi / 4), as Gymnasium draws until one does. All ``draws`` miss with probability 0.215^32 =
        4e-22; the last is then taken anyway. A fixed number of draws, not a loop, keeps automatic
        resets free of a data-dependent loop, which XLA runs on a GPU with a round trip to the host
        at every turn."""
        r = self.target_radius
        points = jax.random.uniform(key, (draws, 2), minval=-r, maxval=r)
        inside = jnp.linalg.norm(points, axis=-1) < r
        first = jnp.where(jnp.any(inside), jnp.argmax(inside), draws - 1)
        return points[first]

    def reward(self, data: Any, action: jax.Array) -> tuple[jax.Array, dict[str, jax.Array]]:
        """``(reward, terms)`` of the state in ``data`` after ``action [2]``."""
        distance = jnp.linalg.norm(self.offset(data))
        reward_dist = -self.reward_dist_weight * distance
        reward_ctrl = -self.reward_control_weight * jnp.sum(jnp.square(action))
        terms = {"reward_dist": reward_dist, "reward_ctrl": reward_ctrl, "task_score": distance}
        return reward_dist + reward_ctrl, terms

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        k_arm, k_target, k_vel = jax.random.split(key, 3)
        s, v = self.arm_noise_scale, self.arm_velocity_noise_scale
        arm = self.init_qpos[:2] + jax.random.uniform(k_arm, (2,), minval=-s, maxval=s)
        qpos = jnp.concatenate([arm, self.sample_target(k_target)])
        qvel = jnp.concatenate([jax.random.uniform(k_vel, (2,), minval=-v, maxval=v), jnp.zeros(2)])
        return self.start_state(qpos, qvel)

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` at ``qpos [nq]``, ``qvel [nv]`` (``MjxEnv.start_state``)."""
        # The observation reads the bodies' positions: the kinematic pass computes them.
        data = self.physics_state(qpos, qvel, kinematics=True)
        _, terms = self.reward(data, jnp.zeros(self.action_size))
        zero = jnp.zeros((), data.qpos.dtype)  # the dtype of the step's metrics: one compiled step
        metrics = {"reward_dist": zero, "reward_ctrl": zero, "task_score": terms["task_score"]}
        return data, self.observation(data), metrics

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        data = self.physics_step(state.data, action)
        reward, terms = self.reward(data, action)
        return data, self.observation(data), reward, jnp.zeros((), bool), terms
