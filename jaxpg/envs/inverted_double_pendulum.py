"""InvertedDoublePendulum with the semantics of Gymnasium's ``InvertedDoublePendulum-v5``.

Observation ``[9]``: cart position ``qpos[0]``, ``sin`` then ``cos`` of the two hinge angles
``qpos[1:]``, ``clip(qvel, -10, 10)`` (3 velocities) and ``clip(qfrc_constraint[0], -10, 10)`` (the
rail limit's force on the cart). Action ``[1]`` in ``[-1, 1]``: the force on the cart (gear 500).

With ``(x, y)`` the tip site's position (horizontal, height) and ``v1, v2`` the hinge velocities,
the reward is ``10 * alive - (0.01 x^2 + (y - 2)^2) - (1e-3 v1^2 + 5e-3 v2^2)``; the episode
terminates, with ``alive = 0``, once ``y <= 1``. Reset noise: uniform +-0.1 on qpos, normal with
standard deviation 0.1 on qvel. Frame skip 5 (dt 0.05 s), 1000-step limit. The task score is the
tip height ``y``.

The tip position and constraint force are those MuJoCo leaves in ``data`` after the step, exactly as
Gymnasium reads them: ``mj_step`` and ``mjx.step`` both run the forward pass before integrating, so
with Euler they belong to the positions at the start of the last physics step, and with RK4 to its
last Runge-Kutta stage.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv


class InvertedDoublePendulum(MjxEnv):
    """MJX InvertedDoublePendulum; see the module docstring for the task definition."""

    task_score_name = "tip_height"

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        healthy_reward: float = 10.0,
        min_tip_height: float = 1.0,
        reset_noise_scale: float = 0.1,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "inverted_double_pendulum.xml",
            frame_skip=5,
            fidelity=fidelity,
            impl=impl,
            max_episode_steps=max_episode_steps,
            **mjx_kwargs,
        )
        self.observation_size = 1 + 2 * (self.nq - 1) + self.nv + 1
        self.action_size = self.mj_model.nu
        self.healthy_reward = healthy_reward
        self.min_tip_height = min_tip_height
        self.reset_noise_scale = reset_noise_scale

    def observation(self, data: Any) -> jax.Array:
        """``[9]`` observation from an ``mjx.Data`` whose derived quantities are up to date."""
        angles = data.qpos[1:]
        return jnp.concatenate(
            [
                data.qpos[:1],
                jnp.sin(angles),
                jnp.cos(angles),
                jnp.clip(data.qvel, -10.0, 10.0),
                jnp.clip(data.qfrc_constraint[:1], -10.0, 10.0),
            ]
        )

    def reward(self, data: Any) -> tuple[jax.Array, jax.Array, dict[str, jax.Array]]:
        """``(reward, terminated, reward terms)`` of the state in ``data``."""
        x, y = data.site_xpos[0, 0], data.site_xpos[0, 2]
        v1, v2 = data.qvel[1], data.qvel[2]
        terminated = y <= self.min_tip_height
        alive = self.healthy_reward * (~terminated).astype(x.dtype)
        distance_penalty = 0.01 * x**2 + (y - 2.0) ** 2
        velocity_penalty = 1e-3 * v1**2 + 5e-3 * v2**2
        terms = {
            "reward_survive": alive,
            "distance_penalty": -distance_penalty,
            "velocity_penalty": -velocity_penalty,
            "task_score": y,
        }
        return alive - distance_penalty - velocity_penalty, terminated, terms

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        kq, kv = jax.random.split(key)
        s = self.reset_noise_scale
        qpos = self.init_qpos + jax.random.uniform(kq, (self.nq,), minval=-s, maxval=s)
        qvel = self.init_qvel + s * jax.random.normal(kv, (self.nv,))
        return self.start_state(qpos, qvel)

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` at ``qpos [nq]``, ``qvel [nv]`` (``MjxEnv.start_state``)."""
        # The observation reads qfrc_constraint, so the reset state needs a forward pass.
        data = self.physics_state(qpos, qvel, forward=True)
        _, _, terms = self.reward(data)
        zero = jnp.zeros((), jnp.float32)
        metrics = {k: zero for k in terms} | {"task_score": terms["task_score"].astype(jnp.float32)}
        return data, self.observation(data), metrics

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        data = self.physics_step(state.data, action)
        reward, terminated, terms = self.reward(data)
        metrics = {k: v.astype(jnp.float32) for k, v in terms.items()}
        return data, self.observation(data), reward, terminated, metrics
