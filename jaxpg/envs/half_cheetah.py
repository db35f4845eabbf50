"""HalfCheetah with the semantics of Gymnasium's ``HalfCheetah-v5``.

Observation ``[17]``: ``qpos[1:]`` (torso height, torso angle, six joint angles) then ``qvel`` (9
velocities), unclipped. Action ``[6]`` in ``[-1, 1]``: torques on the back thigh, shin, foot and
the front thigh, shin, foot (gears 120, 90, 60, 120, 60, 30). Reward: forward velocity of the torso
``(x_after - x_before) / dt`` - 0.1 * |action|^2. The episode never terminates; it ends at the
1000-step limit. Reset noise: uniform +-0.1 on qpos, normal with standard deviation 0.1 on qvel.
Frame skip 5 (dt 0.05 s; the model integrates with Euler at 10 ms in both fidelities).

Metrics: Gymnasium's ``info`` terms ``reward_forward``, ``reward_ctrl`` (negative), ``x_position``
and ``x_velocity``; the task score is the forward distance ``x_position`` (``qpos[0]``).
No deviation from Gymnasium's task.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv


class HalfCheetah(MjxEnv):
    """MJX HalfCheetah; see the module docstring for the task definition."""

    task_score_name = "forward_distance"

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        forward_reward_weight: float = 1.0,
        ctrl_cost_weight: float = 0.1,
        reset_noise_scale: float = 0.1,
        exclude_current_positions_from_observation: bool = True,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "half_cheetah.xml",
            frame_skip=5,
            fidelity=fidelity,
            impl=impl,
            max_episode_steps=max_episode_steps,
            total_mass=14.0,  # Gymnasium's model sets it with the compiler's deprecated settotalmass
            **mjx_kwargs,
        )
        self.skipped_qpos = 1 if exclude_current_positions_from_observation else 0  # qpos[0] is x
        self.observation_size = self.nq - self.skipped_qpos + self.nv
        self.action_size = self.mj_model.nu
        self.forward_reward_weight = forward_reward_weight
        self.ctrl_cost_weight = ctrl_cost_weight
        self.reset_noise_scale = reset_noise_scale

    def observation(self, qpos: jax.Array, qvel: jax.Array) -> jax.Array:
        """``[observation_size]`` observation (17 by default) from ``qpos [9]`` and ``qvel [9]``."""
        return jnp.concatenate([qpos[self.skipped_qpos :], qvel])

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        kq, kv = jax.random.split(key)
        s = self.reset_noise_scale
        qpos = self.init_qpos + jax.random.uniform(kq, (self.nq,), minval=-s, maxval=s)
        qvel = self.init_qvel + s * jax.random.normal(kv, (self.nv,))
        return self.start_state(qpos, qvel)

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` at ``qpos [nq]``, ``qvel [nv]`` (``MjxEnv.start_state``)."""
        data = self.physics_state(qpos, qvel)
        zero = jnp.zeros((), data.qpos.dtype)  # the dtype of the step's metrics: one compiled step
        metrics = {
            "reward_forward": zero,
            "reward_ctrl": zero,
            "x_position": qpos[0],
            "x_velocity": zero,
            "task_score": qpos[0],
        }
        return data, self.observation(qpos, qvel), metrics

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        x_before = state.data.qpos[0]
        data = self.physics_step(state.data, action)
        x_velocity = (data.qpos[0] - x_before) / self.dt
        forward = self.forward_reward_weight * x_velocity
        ctrl_cost = self.ctrl_cost_weight * jnp.sum(jnp.square(action))
        metrics = {
            "reward_forward": forward,
            "reward_ctrl": -ctrl_cost,
            "x_position": data.qpos[0],
            "x_velocity": x_velocity,
            "task_score": data.qpos[0],
        }
        return data, self.observation(data.qpos, data.qvel), forward - ctrl_cost, jnp.zeros((), bool), metrics
