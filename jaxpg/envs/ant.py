"""Ant with the semantics of Gymnasium's ``Ant-v5``.

A quadruped: a spherical torso on a free joint with four two-segment legs (eight hinges), on a
floor it touches with its torso and legs. Observation ``[105]``: ``qpos[2:]`` (torso height, the
torso's orientation quaternion ``w, x, y, z`` as integrated, the eight joint angles: 13), ``qvel``
(14: the torso's linear and angular velocity, the joints'), unclipped, then the external forces on
the 13 bodies after the world, ``cfrc_ext[1:]`` (MuJoCo's ``mj_rnePostConstraint``: per body the
torque and force that the contacts exert about its subtree's centre of mass, 6 each: 78), clipped
to ``contact_force_range`` (-1, 1). Action ``[8]`` in ``[-1, 1]``: torques on the hips and ankles
(gear 150). Reward: forward velocity ``(x_after - x_before) / dt`` of the torso's body frame
(``xpos`` of body 1) + 1 while healthy - 0.5 * |action|^2 - 5e-4 * |clip(cfrc_ext, -1, 1)|^2 (the
contact cost sums over every body, the world's zero row included). Healthy: every entry of qpos and
qvel finite and the torso height ``0.2 <= z <= 1`` (closed range); an unhealthy state terminates
the episode, with no survive reward on that step. Reset noise: uniform +-0.1 on every entry of
qpos (the quaternion too, left unnormalised as in Gymnasium; MuJoCo normalises it where it uses it)
and normal with standard deviation 0.1 on qvel. Frame skip 5 (dt 0.05 s; RK4 at 10 ms in the
"gymnasium" fidelity), 1000-step limit.

Like Gymnasium, the contact forces are those of the physics state that the last MuJoCo step
computed its accelerations at (after an RK4 step, the state of its last stage; after an Euler
step, the state before the step), and the torso's ``xpos`` read for the velocity is of that same
state, a stage behind ``qpos``. The reset observation holds zero contact forces, as Gymnasium's
(``mj_resetData`` zeroes them and its ``mj_forward`` does not compute them); the reset skips
MJX's forward pass and sets the one derived quantity the first step reads, the torso's ``xpos``,
to the free joint's position ``qpos[:3]``, which is what ``mj_forward`` puts there.

MJX implementations: with ``impl="jax"`` the forces come from ``mjx.rne_postconstraint`` after the
``frame_skip`` steps, as Gymnasium calls ``mj_rnePostConstraint``. MJX's ``rne_postconstraint``
accepts only the jax implementation; with ``impl="warp"`` the model's MuJoCo Warp option
``run_rne_postconstraint`` is set, so that every forward pass of the step computes them, the last
one (the same state as above) leaving its forces in the data. That path has run on the CPU only
(warp-lang 1.19, "fast" fidelity): its contact forces are nonzero at the same steps as the jax
implementation's and agree with them to 2.3e-3 over 30 random steps, where the two float32
trajectories have drifted ~1e-3 apart (tests/test_envs.py, test_warp_ant_computes_contact_forces,
over 12 steps). On a GPU the two implementations' contact forces agree in their mean norm over
random steps (BENCHMARKS.md, "What the suite's deviations from Gymnasium cost").

Metrics: Gymnasium's ``info`` terms ``reward_forward``, ``reward_ctrl`` (negative),
``reward_contact`` (negative), ``reward_survive``, ``x_position``, ``y_position``,
``distance_from_origin`` (of ``qpos[:2]``), ``x_velocity`` and ``y_velocity`` (of the torso's
``xpos``); the task score is the forward distance ``x_position`` (``qpos[0]``).

Deviation from Gymnasium's physics, in both fidelities and both MJX implementations (MuJoCo 3.17):
MJX orients the tangent frame of a capsule's contacts with the floor differently from MuJoCo.
MuJoCo aligns the first tangent with the capsule's axis projected on the floor; MJX (its jax
implementation and MuJoCo Warp) does so only while the capsule lies within 60 degrees of
horizontal and uses a fixed world axis for steeper capsules, as the ant's lower legs usually are
when they touch the floor. With the model's pyramidal friction cone (four edges along the two
tangents) the friction forces depend on that orientation, so from the first such contact the
"gymnasium" fidelity's trajectories part from Gymnasium's by O(1) within a few steps (not a
rounding effect). Everything that jaxpg computes from the physics (observation, contact forces,
reward, termination) is Gymnasium's: with MuJoCo's frame convention swapped into MJX's collider,
as tests/test_envs.py does, whole episodes agree to rounding. The planar tasks (Hopper, Walker2d,
HalfCheetah) are not affected: there both conventions give the same pyramid. What it costs a
policy: BENCHMARKS.md, "What the suite's deviations from Gymnasium cost" (a PPO policy trained in the
"gymnasium" fidelity, replayed in jaxpg and in Gymnasium's Ant-v5).

Other deviations from Gymnasium: ``main_body`` is fixed to body 1 (the torso) and the options
``exclude_current_positions_from_observation`` and ``include_cfrc_ext_in_observation`` are taken
with Gymnasium's meaning; ``xml_file`` and a custom ``frame_skip`` are not. The warp
implementation's defaults for the contact and constraint buffers are raised to the most the ant
can have (``naconmax`` 32 per env: 25 contacts with the floor at most, a sphere's one and two per
capsule; ``njmax`` 128: 4 pyramidal friction rows per contact and 8 joint limits).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv, mjx, planar_position_metrics

TORSO = 1  # body index of the torso (Gymnasium's ``main_body``)


class Ant(MjxEnv):
    """MJX Ant; see the module docstring for the task definition."""

    derived_fields_read = ("xpos",)
    task_score_name = "forward_distance"

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        forward_reward_weight: float = 1.0,
        ctrl_cost_weight: float = 0.5,
        contact_cost_weight: float = 5e-4,
        healthy_reward: float = 1.0,
        terminate_when_unhealthy: bool = True,
        healthy_z_range: tuple[float, float] = (0.2, 1.0),
        contact_force_range: tuple[float, float] = (-1.0, 1.0),
        reset_noise_scale: float = 0.1,
        exclude_current_positions_from_observation: bool = True,
        include_cfrc_ext_in_observation: bool = True,
        **mjx_kwargs: Any,
    ):
        mjx_kwargs.setdefault("naconmax", 32)
        mjx_kwargs.setdefault("njmax", 128)
        super().__init__(
            "ant.xml",
            frame_skip=5,
            fidelity=fidelity,
            impl=impl,
            max_episode_steps=max_episode_steps,
            **mjx_kwargs,
        )
        if self.impl == "warp":  # MJX's rne_postconstraint is jax-only: let MuJoCo Warp's forward compute it
            opt = self.mjx_model.opt
            self.mjx_model = self.mjx_model.replace(
                opt=opt.replace(_impl=opt._impl.replace(run_rne_postconstraint=True))
            )
        self.forward_reward_weight = forward_reward_weight
        self.ctrl_cost_weight = ctrl_cost_weight
        self.contact_cost_weight = contact_cost_weight
        self.healthy_reward = healthy_reward
        self.terminate_when_unhealthy = terminate_when_unhealthy
        self.healthy_z_range = healthy_z_range
        self.contact_force_range = contact_force_range
        self.reset_noise_scale = reset_noise_scale
        self.skipped_qpos = 2 if exclude_current_positions_from_observation else 0
        self.include_cfrc_ext = include_cfrc_ext_in_observation
        self.nbody = self.mj_model.nbody
        self.observation_size = self.nq - self.skipped_qpos + self.nv
        self.observation_size += 6 * (self.nbody - 1) * include_cfrc_ext_in_observation
        self.action_size = self.mj_model.nu

    def physics_step(self, data: Any, ctrl: jax.Array) -> Any:
        """``MjxEnv.physics_step``, then the external forces ``cfrc_ext`` of the resulting data (the
        warp implementation computed them in its forward passes, see the module docstring)."""
        data = super().physics_step(data, ctrl)
        if self.impl == "jax":
            data = mjx.rne_postconstraint(self.mjx_model, data)
        return data

    def contact_forces(self, data: Any) -> jax.Array:
        """``[nbody, 6]``: ``cfrc_ext`` of ``data`` clipped to ``contact_force_range``."""
        low, high = self.contact_force_range
        return jnp.clip(data._impl.cfrc_ext, low, high)

    def observation(self, qpos: jax.Array, qvel: jax.Array, contact_forces: jax.Array) -> jax.Array:
        """``[observation_size]`` observation from ``qpos [15]``, ``qvel [14]`` and the clipped
        ``contact_forces [14, 6]``."""
        parts = [qpos[self.skipped_qpos :], qvel]
        if self.include_cfrc_ext:
            parts.append(contact_forces[1:].reshape(-1).astype(qpos.dtype))
        return jnp.concatenate(parts)

    def is_healthy(self, qpos: jax.Array, qvel: jax.Array) -> jax.Array:
        """``[]`` bool: qpos and qvel are finite and the torso height is in the (closed) healthy range."""
        z_min, z_max = self.healthy_z_range
        finite = jnp.all(jnp.isfinite(qpos)) & jnp.all(jnp.isfinite(qvel))
        return finite & (z_min <= qpos[2]) & (qpos[2] <= z_max)

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        kq, kv = jax.random.split(key)
        s = self.reset_noise_scale
        qpos = self.init_qpos + jax.random.uniform(kq, (self.nq,), minval=-s, maxval=s)
        qvel = self.init_qvel + s * jax.random.normal(kv, (self.nv,))
        return self.start_state(qpos, qvel)

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` at ``qpos [nq]``, ``qvel [nv]`` (``MjxEnv.start_state``)."""
        data = self.physics_state(qpos, qvel)
        # What mj_forward would give the first step's x_before: a free body's xpos is its joint's position.
        data = data.replace(xpos=data.xpos.at[TORSO].set(data.qpos[:3]))
        zero = jnp.zeros((), data.qpos.dtype)  # the dtype of the step's metrics: one compiled step
        metrics = {
            "reward_forward": zero,
            "reward_ctrl": zero,
            "reward_contact": zero,
            "reward_survive": zero,
            "x_velocity": zero,
            "y_velocity": zero,
            **planar_position_metrics(qpos),
        }
        return data, self.observation(qpos, qvel, self.contact_forces(data)), metrics

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        xy_before = state.data.xpos[TORSO, :2]
        data = self.physics_step(state.data, action)
        xy_velocity = (data.xpos[TORSO, :2] - xy_before) / self.dt
        healthy = self.is_healthy(data.qpos, data.qvel)
        contact_forces = self.contact_forces(data)
        forward = self.forward_reward_weight * xy_velocity[0]
        survive = self.healthy_reward * healthy.astype(forward.dtype)
        ctrl_cost = self.ctrl_cost_weight * jnp.sum(jnp.square(action))
        contact_cost = self.contact_cost_weight * jnp.sum(jnp.square(contact_forces))
        metrics = {
            "reward_forward": forward,
            "reward_ctrl": -ctrl_cost,
            "reward_contact": -contact_cost,
            "reward_survive": survive,
            "x_velocity": xy_velocity[0],
            "y_velocity": xy_velocity[1],
            **planar_position_metrics(data.qpos),
        }
        reward = forward + survive - ctrl_cost - contact_cost
        terminated = ~healthy & self.terminate_when_unhealthy
        return data, self.observation(data.qpos, data.qvel, contact_forces), reward, terminated, metrics
