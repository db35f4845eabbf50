"""InvertedPendulum with the semantics of Gymnasium's ``InvertedPendulum-v5``.

Observation ``[4]``: ``qpos`` (cart position, pole angle) then ``qvel`` (their velocities), unclipped.
Action ``[1]`` in ``[-3, 3]``: the force on the cart (gear 100). Reward: 1 while the pole is upright
(``|angle| <= 0.2``), 0 on the step that tips it over, which terminates the episode (v5 gives no
reward on that step; v4 did). Reset noise: uniform +-0.01 on qpos and qvel. Frame skip 2
(dt 0.04 s), 1000-step limit. The task score is the number of upright steps so far, which at the
end of an episode equals its return (1000 for a perfect episode).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv


class InvertedPendulum(MjxEnv):
    """MJX InvertedPendulum; see the module docstring for the task definition."""

    task_score_name = "upright_steps"
    action_low = -3.0
    action_high = 3.0

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        max_angle: float = 0.2,
        reset_noise_scale: float = 0.01,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "inverted_pendulum.xml",
            frame_skip=2,
            fidelity=fidelity,
            impl=impl,
            max_episode_steps=max_episode_steps,
            **mjx_kwargs,
        )
        self.observation_size = self.nq + self.nv
        self.action_size = self.mj_model.nu
        self.max_angle = max_angle
        self.reset_noise_scale = reset_noise_scale

    def observation(self, qpos: jax.Array, qvel: jax.Array) -> jax.Array:
        """``[4]`` observation from ``qpos [2]`` and ``qvel [2]``."""
        return jnp.concatenate([qpos, qvel])

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        kq, kv = jax.random.split(key)
        s = self.reset_noise_scale
        qpos = self.init_qpos + jax.random.uniform(kq, (self.nq,), minval=-s, maxval=s)
        qvel = self.init_qvel + jax.random.uniform(kv, (self.nv,), minval=-s, maxval=s)
        return self.start_state(qpos, qvel)

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` at ``qpos [nq]``, ``qvel [nv]`` (``MjxEnv.start_state``)."""
        metrics = {"reward_survive": jnp.zeros((), jnp.float32), "task_score": jnp.zeros((), jnp.float32)}
        return self.physics_state(qpos, qvel), self.observation(qpos, qvel), metrics

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        data = self.physics_step(state.data, action)
        obs = self.observation(data.qpos, data.qvel)
        # Gymnasium compares the observation, i.e. `|angle| > 0.2` ends the episode.
        terminated = jnp.abs(obs[1]) > self.max_angle
        reward = (~terminated).astype(jnp.float32)
        upright_steps = state.info["step"].astype(jnp.float32) + reward
        metrics = {"reward_survive": reward, "task_score": upright_steps}
        return data, obs, reward, terminated, metrics
