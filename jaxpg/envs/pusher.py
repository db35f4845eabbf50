"""Pusher with the semantics of Gymnasium's ``Pusher-v5``.

A seven-joint arm pushes a cylinder (the object) across a table to a fixed goal; no gravity.
Observation ``[23]``: the arm's joint angles ``qpos[:7]`` and velocities ``qvel[:7]``, then the
positions (body frames, ``xpos``) of the fingertip ``tips_arm``, the object and the goal. Action
``[7]`` in ``[-2, 2]``: the joint torques (gear 1). With ``tip``, ``obj``, ``goal`` those positions
after the step, the reward is ``-0.5 |obj - tip| - |obj - goal| - 0.1 |action|^2``: ``reward_near``,
``reward_dist`` and ``reward_ctrl`` (as Gymnasium's ``info`` has them; v5 reads the positions after
the step, and ``reward_near`` is measured to the object, as Gymnasium computes it, whatever its
documentation says). Never terminates; 100-step limit. Frame skip 5 (dt 0.05 s).

Reset: the arm at its zero pose with joint velocities uniform in +-5e-3; the object's slide joints
``qpos[7:9]`` (y then x, in the model's order) drawn from uniform(-0.3, 0) and uniform(-0.2, 0.2)
until the object lies more than 0.17 from the goal (Gymnasium's rejection loop, here a
``lax.while_loop``); the goal's slide joints at 0 and the object and goal at rest.

The positions are those MuJoCo leaves in ``data`` after the step, exactly as Gymnasium reads them:
``mj_step`` and ``mjx.step`` both run the forward pass before integrating, so they belong to the
positions at the start of the last physics step. The task score is the object's distance to the
goal ``|obj - goal|`` (lower is better).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import mujoco

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv


class Pusher(MjxEnv):
    """MJX Pusher; see the module docstring for the task definition."""

    task_score_name = "object_goal_distance"
    # Its arm's chain of seven hinges makes XLA:CPU's fusion emitters orders of magnitude slower on
    # its step: see jaxpg.envs.compile_options.
    cpu_fusion_emitters = False
    action_low = -2.0
    action_high = 2.0

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 100,
        reward_near_weight: float = 0.5,
        reward_dist_weight: float = 1.0,
        reward_control_weight: float = 0.1,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "pusher.xml",
            frame_skip=5,
            fidelity=fidelity,
            impl=impl,
            max_episode_steps=max_episode_steps,
            **mjx_kwargs,
        )
        self.observation_size = 7 + 7 + 3 * 3
        self.action_size = self.mj_model.nu
        self.reward_near_weight = reward_near_weight
        self.reward_dist_weight = reward_dist_weight
        self.reward_control_weight = reward_control_weight
        body = lambda name: mujoco.mj_name2id(self.mj_model, mujoco.mjtObj.mjOBJ_BODY, name)  # noqa: E731
        self.tip_body, self.object_body, self.goal_body = body("tips_arm"), body("object"), body("goal")

    def observation(self, data: Any) -> jax.Array:
        """``[23]`` observation from an ``mjx.Data`` whose body positions are up to date."""
        positions = data.xpos[jnp.array([self.tip_body, self.object_body, self.goal_body])]
        return jnp.concatenate([data.qpos[:7], data.qvel[:7], positions.reshape(-1)])

    def reward_terms(self, data: Any, action: jax.Array) -> dict[str, jax.Array]:
        """``reward_near``, ``reward_dist``, ``reward_ctrl`` (scalars) and ``task_score``."""
        tip, obj, goal = data.xpos[self.tip_body], data.xpos[self.object_body], data.xpos[self.goal_body]
        distance = jnp.linalg.norm(obj - goal)
        return {
            "reward_near": -self.reward_near_weight * jnp.linalg.norm(obj - tip),
            "reward_dist": -self.reward_dist_weight * distance,
            "reward_ctrl": -self.reward_control_weight * jnp.sum(jnp.square(action)),
            "task_score": distance,
        }

    def sample_object_position(self, key: jax.Array) -> jax.Array:
        """``[2]``: the object's slide joints (y, x), redrawn until more than 0.17 from the goal."""

        def draw(k: jax.Array) -> jax.Array:
            k1, k2 = jax.random.split(k)
            first = jax.random.uniform(k1, (1,), minval=-0.3, maxval=0.0)
            second = jax.random.uniform(k2, (1,), minval=-0.2, maxval=0.2)
            return jnp.concatenate([first, second])

        def redraw(carry: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
            k, _ = carry
            k, sub = jax.random.split(k)
            return k, draw(sub)

        key, sub = jax.random.split(key)
        _, position = jax.lax.while_loop(lambda c: jnp.linalg.norm(c[1]) <= 0.17, redraw, (key, draw(sub)))
        return position

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        k_object, k_vel = jax.random.split(key)
        object_position = self.sample_object_position(k_object).astype(self.init_qpos.dtype)
        qpos = self.init_qpos.at[7:9].set(object_position).at[9:].set(0.0)
        qvel = jax.random.uniform(k_vel, (self.nv,), minval=-5e-3, maxval=5e-3).at[7:].set(0.0)
        return self.start_state(qpos, qvel)

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` at ``qpos [nq]``, ``qvel [nv]`` (``MjxEnv.start_state``)."""
        data = self.physics_state(qpos, qvel, kinematics=True)  # the observation reads body positions
        terms = self.reward_terms(data, jnp.zeros(self.action_size))
        metrics = {k: jnp.zeros((), jnp.float32) for k in terms} | {"task_score": terms["task_score"]}
        return data, self.observation(data), {k: v.astype(jnp.float32) for k, v in metrics.items()}

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        data = self.physics_step(state.data, action)
        terms = self.reward_terms(data, action)
        reward = terms["reward_near"] + terms["reward_dist"] + terms["reward_ctrl"]
        metrics = {k: v.astype(jnp.float32) for k, v in terms.items()}
        return data, self.observation(data), reward, jnp.zeros((), bool), metrics
