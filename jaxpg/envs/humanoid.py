"""Humanoid with the semantics of Gymnasium's ``Humanoid-v5``.

Observation ``[348]``, read from the physics after the step: ``qpos[2:]`` (torso height, torso
orientation quaternion, the 17 hinge angles; 22), ``qvel`` (23), the bodies' composite inertias
``cinert[1:]`` (13 x 10 = 130) and spatial velocities ``cvel[1:]`` (13 x 6 = 78) about the centre of
mass, the actuator forces on the hinges ``qfrc_actuator[6:]`` (17) and the external (contact) forces
on the bodies ``cfrc_ext[1:]`` (13 x 6 = 78). Action ``[17]`` in ``[-0.4, 0.4]``: the hinge motors
(gears 25-300). Reward: ``1.25 *`` the x-velocity of the centre of mass (the mass-weighted mean of
the bodies' ``xipos``, differenced over the step) ``+ 5`` while healthy ``- 0.1 |action|^2 -
min(5e-7 * sum(cfrc_ext^2), 10)``. Healthy: torso height ``1 < qpos[2] < 2``; an unhealthy state
terminates the episode (unless ``terminate_when_unhealthy=False``), with no survive reward on that
step. Reset noise: uniform +-1e-2 on qpos and qvel. Frame skip 5 (dt 0.015 s), 1000-step limit.
Gymnasium's keywords ``exclude_current_positions_from_observation`` (``False``: ``qpos`` whole, 24)
and ``include_{cinert,cvel,qfrc_actuator,cfrc_ext}_in_observation`` choose the observation's parts,
as in Gymnasium; the contact cost reads ``cfrc_ext`` whether it is observed or not.

As in Gymnasium, the derived quantities (``cinert``, ``cvel``, ``xipos``, ``qfrc_actuator``) are
those MuJoCo leaves in ``data`` after the step: ``mjx.step`` and ``mj_step`` both run the forward
pass before integrating (RK4: at its last stage), so they belong to the state at the start of the
last physics step. ``cfrc_ext`` is filled after the steps by ``mjx.rne_postconstraint`` (MJX's jax
impl), as Gymnasium fills it with ``mj_rnePostConstraint``; with MuJoCo Warp the model's
``run_rne_postconstraint`` option makes every step compute it (``mjx.rne_postconstraint`` itself
raises for warp, so a missing ``cfrc_ext`` cannot pass silently). On a GPU the two
implementations' contact forces agree in their mean norm over random steps (BENCHMARKS.md, "What
the suite's deviations from Gymnasium cost").
At reset the observation is that of Gymnasium's reset (a forward pass at the reset state, no
control, ``cfrc_ext`` zero), from the kinematic and velocity passes alone (``physics_state``).

Metrics: Gymnasium's ``info`` terms ``reward_survive``, ``reward_forward``, ``reward_ctrl``,
``reward_contact`` (costs negative), ``x_position``, ``y_position`` (the torso's, ``qpos[0:2]``),
``distance_from_origin`` (of the torso in x-y), ``x_velocity`` and ``y_velocity`` (of the centre of
mass); not its ``tendon_length`` and ``tendon_velocity`` (arrays of the two hip-knee tendons; jaxpg's
metrics are scalars). The task score is the forward distance ``x_position``.

Deviations from Gymnasium, in fidelity ``"gymnasium"`` (RK4 at 3 ms and everything else as in
Gymnasium's model):

- Solver: the model asks for PGS (50 iterations), which MJX does not have (``mjx.put_model`` raises
  ``NotImplementedError``); ``load_model`` gives it Newton, MJX's default, in both fidelities. Both
  solve the same convex problem and Newton converges within its 50 iterations; of MJX's two solvers
  it stays the closer to PGS (CG parts from it at the first step in some episodes). Measured in
  MuJoCo itself (Gymnasium's env with its model untouched and switched to Newton, 8 seeded resets,
  the same random actions; ``test_humanoid_newton_in_place_of_pgs``): the random episodes (17-37
  steps) end at the same step; qpos and qvel agree within 1e-6 for the first 5-20 steps, then part
  by at most 9e-6 by the termination (observation 8e-5 relative to ``max(1, |obs|)``, reward 5e-7);
  past it the fallen humanoid amplifies that, to 1e-5..2e-4 in qpos and qvel after 100 steps, and to
  0.66 on one seed of 8.
- Collisions: MJX's collision detection for Humanoid's capsules is not MuJoCo's to rounding. A
  capsule lying on the floor gets another contact frame (the tangent directions, which orient the
  pyramidal friction cone of the condim-3 floor contacts), and capsule-capsule distances differ by
  ~1e-8. From the same state a physics step with such a contact then parts MJX and MuJoCo by
  1e-5..1e-2 in qvel. Random episodes mostly touch the floor with the feet (spheres) alone: with the
  solver switched to Newton in Gymnasium's env too, 8 of 12 float64 episodes agree with it to
  rounding up to termination, 4 part by up to 6e-5 (the episodes still end at the same step).
  ``tests/test_envs.py::test_gymnasium_parity_humanoid`` has the numbers.

What both cost a policy: BENCHMARKS.md, "What the suite's deviations from Gymnasium cost" (a PPO
policy trained in the "gymnasium" fidelity, replayed in jaxpg and in Gymnasium's Humanoid-v5).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxpg.envs.base import State
from jaxpg.envs.mjx_env import Fidelity, Impl, MjxEnv, mjx, planar_position_metrics


class HumanoidBase(MjxEnv):
    """What Humanoid and HumanoidStandup share: Gymnasium's 17-motor humanoid model (``xml_file``)
    at frame skip 5, its observation (``[348]`` with every part; Gymnasium's keywords choose the
    parts) with the external forces ``cfrc_ext`` after the step, and the reset noise; the tasks
    add their rewards."""

    action_low = -0.4
    action_high = 0.4

    def __init__(
        self,
        xml_file: str,
        fidelity: Fidelity,
        impl: Impl | None,
        max_episode_steps: int,
        reset_noise_scale: float,
        naconmax: int,
        njmax: int,
        exclude_current_positions_from_observation: bool = True,
        include_cinert_in_observation: bool = True,
        include_cvel_in_observation: bool = True,
        include_qfrc_actuator_in_observation: bool = True,
        include_cfrc_ext_in_observation: bool = True,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            xml_file,
            frame_skip=5,
            fidelity=fidelity,
            impl=impl,
            max_episode_steps=max_episode_steps,
            naconmax=naconmax,
            njmax=njmax,
            **mjx_kwargs,
        )
        if self.impl == "warp":  # MuJoCo Warp fills cfrc_ext only when asked to (Gymnasium calls for it)
            opt = self.mjx_model.opt
            opt = opt.replace(_impl=opt._impl.replace(run_rne_postconstraint=True))
            self.mjx_model = self.mjx_model.replace(opt=opt)
        # The observation's parts, Gymnasium's keywords: qpos (less the torso's x-y when excluded),
        # qvel, then each of cinert, cvel, qfrc_actuator and cfrc_ext that is included.
        self.skipped_qpos = 2 if exclude_current_positions_from_observation else 0
        self.observed = {
            "cinert": include_cinert_in_observation,
            "cvel": include_cvel_in_observation,
            "qfrc_actuator": include_qfrc_actuator_in_observation,
            "cfrc_ext": include_cfrc_ext_in_observation,
        }
        body_rows = self.mj_model.nbody - 1
        sizes = {
            "cinert": body_rows * 10,
            "cvel": body_rows * 6,
            "qfrc_actuator": self.nv - 6,
            "cfrc_ext": body_rows * 6,
        }
        self.observation_size = (self.nq - self.skipped_qpos) + self.nv
        self.observation_size += sum(size for name, size in sizes.items() if self.observed[name])
        self.action_size = self.mj_model.nu
        self.reset_noise_scale = reset_noise_scale

    def physics_step(self, data: Any, ctrl: jax.Array) -> Any:
        """``frame_skip`` MJX steps, then the bodies' external forces ``cfrc_ext`` (jax impl: by
        ``mjx.rne_postconstraint``, as Gymnasium calls ``mj_rnePostConstraint``; warp: computed in
        every step, see ``__init__``)."""
        data = super().physics_step(data, ctrl)
        if self.impl == "jax":
            data = mjx.rne_postconstraint(self.mjx_model, data)
        return data

    def physics_state(self, qpos: jax.Array, qvel: jax.Array, forward: bool = False) -> Any:
        """``MjxEnv.physics_state``, where ``forward`` brings up to date what the observation, the
        centre of mass and Gymnasium's ``info`` read (``xipos``, ``cinert``, ``cvel``, the tendons'
        lengths and velocities) by the kinematic and velocity passes alone: no collision or
        constraint solve, which a full forward pass would add to every automatic reset (with MuJoCo
        Warp a fifth of a physics step of this frame skip). The actuator and contact forces stay
        zero, as after Gymnasium's reset (no control, ``cfrc_ext`` not computed).

        MJX's kinematics writes the torso's quaternion back into ``qpos`` normalised, which MuJoCo's
        does not: Gymnasium's reset state and observation keep the noisy quaternion (MuJoCo normalises
        it when it integrates, as MJX does in every step), so ``qpos`` stays as given."""
        data = super().physics_state(qpos, qvel)
        if forward:
            # (tendon: its fields too, in the dtypes a step gives them, so that reset and step states match)
            for stage in (mjx.kinematics, mjx.com_pos, mjx.tendon):
                data = stage(self.mjx_model, data)
            data = self.velocity_pass(data)
        return data.replace(qpos=qpos.astype(data.qpos.dtype))

    def velocity_pass(self, data: Any) -> Any:
        """``data`` with the bodies' velocities ``cvel [nbody, 6]`` and the tendons' velocities
        ``ten_velocity [ntendon]`` of MuJoCo's velocity pass (``mj_comVel``, ``mj_fwdVelocity``),
        from the motion axes ``cdof`` and tendon Jacobian ``ten_J`` of the position passes: each
        body moves as its parent plus its own joints, ``cvel[b] = cvel[parent(b)] + sum over b's
        dofs of cdof[j] * qvel[j]``, and ``ten_velocity = ten_J qvel``. (MJX's ``com_vel`` has no
        MuJoCo Warp implementation, and neither implementation's ``tendon`` computes the tendons'
        velocities, which Gymnasium's ``info`` reports.)"""
        m = self.mj_model
        per_dof = data.cdof * data.qvel[:, None]
        cvel = [jnp.zeros(6, data.cvel.dtype)]
        for body in range(1, m.nbody):  # parents come first in MuJoCo's body order
            own = per_dof[m.body_dofadr[body] : m.body_dofadr[body] + m.body_dofnum[body]].sum(0)
            cvel.append(cvel[m.body_parentid[body]] + own)
        ten_jacobian = data._impl.ten_J
        if ten_jacobian.shape == (m.ntendon, m.nv):
            ten_velocity = ten_jacobian @ data.qvel
        else:  # MuJoCo's sparse layout: tendon t's entries at ten_J_rowadr[t] + (0 .. ten_J_rownnz[t])
            entries = np.concatenate(
                [adr + np.arange(n) for adr, n in zip(m.ten_J_rowadr, m.ten_J_rownnz, strict=True)]
            )
            rows = np.repeat(np.arange(m.ntendon), m.ten_J_rownnz)
            products = ten_jacobian[entries] * data.qvel[m.ten_J_colind[entries]]
            ten_velocity = jax.ops.segment_sum(products, rows, m.ntendon)
        data = data.replace(cvel=jnp.stack(cvel))
        return data.replace(_impl=data._impl.replace(ten_velocity=ten_velocity.astype(data._impl.ten_velocity.dtype)))

    def reset_state(self, key: jax.Array) -> Any:
        """The physics state of a reset (``forward``, see ``physics_state``): uniform noise of
        +-``reset_noise_scale`` on the model's ``qpos0`` and on zero ``qvel``."""
        kq, kv = jax.random.split(key)
        s = self.reset_noise_scale
        qpos = self.init_qpos + jax.random.uniform(kq, (self.nq,), minval=-s, maxval=s)
        qvel = self.init_qvel + jax.random.uniform(kv, (self.nv,), minval=-s, maxval=s)
        return self.physics_state(qpos, qvel, forward=True)

    def observation(self, data: Any) -> jax.Array:
        """``[observation_size]`` observation (348 by default) from an ``mjx.Data`` after a step (or
        a forward pass at reset), its parts chosen by Gymnasium's keywords (``__init__``)."""
        impl = data._impl
        parts = {
            "cinert": impl.cinert[1:].reshape(-1),
            "cvel": data.cvel[1:].reshape(-1),
            "qfrc_actuator": data.qfrc_actuator[6:],
            "cfrc_ext": impl.cfrc_ext[1:].reshape(-1),
        }
        observed = [part for name, part in parts.items() if self.observed[name]]
        return jnp.concatenate([data.qpos[self.skipped_qpos :], data.qvel, *observed])

    @staticmethod
    def external_force_cost(data: Any, weight: float, cost_range: tuple[float, float]) -> jax.Array:
        """``[]`` ``weight`` times the sum of the squared external forces ``cfrc_ext`` (all bodies),
        clipped to ``cost_range``: Humanoid's contact cost, HumanoidStandup's impact cost."""
        return jnp.clip(weight * jnp.sum(jnp.square(data._impl.cfrc_ext)), *cost_range)


class Humanoid(HumanoidBase):
    """MJX Humanoid; see the module docstring for the task definition."""

    derived_fields_read = ("xipos", "ten_length", "ten_velocity")
    task_score_name = "forward_distance"

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        forward_reward_weight: float = 1.25,
        ctrl_cost_weight: float = 0.1,
        contact_cost_weight: float = 5e-7,
        contact_cost_range: tuple[float, float] = (-np.inf, 10.0),
        healthy_reward: float = 5.0,
        terminate_when_unhealthy: bool = True,
        healthy_z_range: tuple[float, float] = (1.0, 2.0),
        reset_noise_scale: float = 1e-2,
        exclude_current_positions_from_observation: bool = True,
        include_cinert_in_observation: bool = True,
        include_cvel_in_observation: bool = True,
        include_qfrc_actuator_in_observation: bool = True,
        include_cfrc_ext_in_observation: bool = True,
        # warp capacities per env: MuJoCo's Humanoid-v5 (Newton) peaked at 10 contacts and 34 constraint
        # rows over 6 x 1000 random steps, mostly fallen
        naconmax: int = 32,
        njmax: int = 128,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "humanoid.xml",
            fidelity,
            impl,
            max_episode_steps,
            reset_noise_scale,
            naconmax,
            njmax,
            exclude_current_positions_from_observation=exclude_current_positions_from_observation,
            include_cinert_in_observation=include_cinert_in_observation,
            include_cvel_in_observation=include_cvel_in_observation,
            include_qfrc_actuator_in_observation=include_qfrc_actuator_in_observation,
            include_cfrc_ext_in_observation=include_cfrc_ext_in_observation,
            **mjx_kwargs,
        )
        self.terminate_when_unhealthy = terminate_when_unhealthy
        self.forward_reward_weight = forward_reward_weight
        self.ctrl_cost_weight = ctrl_cost_weight
        self.contact_cost_weight = contact_cost_weight
        self.contact_cost_range = contact_cost_range
        self.healthy_reward = healthy_reward
        self.healthy_z_range = healthy_z_range
        self.body_mass = np.asarray(self.mj_model.body_mass)

    def mass_center(self, data: Any) -> jax.Array:
        """``[2]`` x-y of the centre of mass: the bodies' ``xipos`` weighted by their masses."""
        mass = jnp.asarray(self.body_mass, data.xipos.dtype)
        return (mass @ data.xipos)[:2] / self.body_mass.sum()

    def is_healthy(self, qpos: jax.Array) -> jax.Array:
        """``[]`` bool: the torso's height is inside the (open) healthy range."""
        z_min, z_max = self.healthy_z_range
        return (z_min < qpos[2]) & (qpos[2] < z_max)

    def contact_cost(self, data: Any) -> jax.Array:
        """``[]`` weighted sum of the squared external forces, clipped to ``contact_cost_range``."""
        return self.external_force_cost(data, self.contact_cost_weight, self.contact_cost_range)

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        return self._start_from(self.reset_state(key))

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` at ``qpos [nq]``, ``qvel [nv]`` (``MjxEnv.start_state``)."""
        return self._start_from(self.physics_state(qpos, qvel, forward=True))

    def _start_from(self, data: Any) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` from its physics state ``data`` (after a forward pass)."""
        zero = jnp.zeros((), data.qpos.dtype)  # the dtype of the step's metrics: one compiled step
        metrics = {
            "reward_survive": zero,
            "reward_forward": zero,
            "reward_ctrl": zero,
            "reward_contact": zero,
            "x_velocity": zero,
            "y_velocity": zero,
            **planar_position_metrics(data.qpos),
        }
        return data, self.observation(data), metrics

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        xy_before = self.mass_center(state.data)
        data = self.physics_step(state.data, action)
        x_velocity, y_velocity = (self.mass_center(data) - xy_before) / self.dt
        healthy = self.is_healthy(data.qpos)
        forward = self.forward_reward_weight * x_velocity
        survive = self.healthy_reward * healthy.astype(x_velocity.dtype)
        ctrl_cost = self.ctrl_cost_weight * jnp.sum(jnp.square(action))
        contact_cost = self.contact_cost(data)
        metrics = {
            "reward_survive": survive,
            "reward_forward": forward,
            "reward_ctrl": -ctrl_cost,
            "reward_contact": -contact_cost,
            "x_velocity": x_velocity,
            "y_velocity": y_velocity,
            **planar_position_metrics(data.qpos),
        }
        reward = (forward + survive) - (ctrl_cost + contact_cost)  # Gymnasium's order of the sums
        terminated = ~healthy if self.terminate_when_unhealthy else jnp.zeros_like(healthy)
        return data, self.observation(data), reward, terminated, metrics
