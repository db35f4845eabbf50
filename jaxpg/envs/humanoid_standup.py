"""HumanoidStandup with the semantics of Gymnasium's ``HumanoidStandup-v5``.

Humanoid's body, observation and physics (``jaxpg/envs/humanoid.py``, whose ``HumanoidBase`` this
task shares), started lying on the floor (``humanoid_standup.xml``: torso at height 0.105, waist and
legs stretched along x). Observation ``[348]``: ``qpos[2:]``, ``qvel``, ``cinert[1:]``, ``cvel[1:]``,
``qfrc_actuator[6:]``, ``cfrc_ext[1:]``, read after the step as in Humanoid (and its parts chosen
by the same Gymnasium keywords, ``exclude_current_positions_from_observation`` and
``include_{cinert,cvel,qfrc_actuator,cfrc_ext}_in_observation``). Action ``[17]`` in
``[-0.4, 0.4]``. Reward: the torso's height over the model's timestep (``qpos[2] / 0.003``, not over
the env step ``dt``) ``- 0.1 |action|^2 - min(0.5e-6 * sum(cfrc_ext^2), 10) + 1``. No termination:
every episode runs to the 1000-step limit. Reset noise: uniform +-1e-2 on qpos and qvel. Frame skip
5 (dt 0.015 s).

Metrics: Gymnasium's ``info`` terms ``reward_linup``, ``reward_quadctrl``, ``reward_impact`` (costs
negative), ``x_position``, ``y_position`` (the torso's) and ``z_distance_from_origin`` (the torso's
height above its initial 0.105); not its ``tendon_length`` and ``tendon_velocity`` (arrays; the
Gymnasium API reads them from the physics state). The task score is the torso's height ``qpos[2]``.
Gymnasium's env takes ``uph_cost_weight`` and ignores it; here it scales the height term (default
1: Gymnasium's reward).

Deviations from Gymnasium, in fidelity ``"gymnasium"`` (RK4 at 3 ms and everything else as in
Gymnasium's model), Humanoid's two (``humanoid.py``), which weigh more here: the body lies on the
floor and flails there for the whole episode, touching the floor and itself.

- Solver: Newton in place of the model's PGS, which MJX does not have (``load_model``). Measured in
  MuJoCo itself (Gymnasium's env with its model untouched and switched to Newton, 8 seeded resets,
  the same random actions; ``tests/test_envs.py::test_humanoid_standup_newton_in_place_of_pgs``):
  the two part by 2e-6..1e-5 in qpos and qvel at the first step and by up to 9e-5 within 50 steps,
  and the flailing body amplifies that to O(1) after 200-470 steps.
- Collisions: against MuJoCo with Newton too, MJX repeats Gymnasium's steps to rounding, the floor
  contacts and most contacts of the body with itself included, for the first 13-128 steps of the
  random episodes of seeds 0-3. Then a hand, a foot or a thigh presses on a leg's capsule, a
  contact whose normal MJX computes 4e-6..3e-5 apart from MuJoCo's (the distances agree to 1e-11),
  and the trajectories part, by 0.1 in qvel after 220-420 steps.
  ``tests/test_envs.py::test_gymnasium_parity_humanoid_standup`` has the numbers.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxpg.envs.base import State
from jaxpg.envs.humanoid import HumanoidBase
from jaxpg.envs.mjx_env import Fidelity, Impl


class HumanoidStandup(HumanoidBase):
    """MJX HumanoidStandup; see the module docstring for the task definition."""

    derived_fields_read = ("ten_length", "ten_velocity")
    task_score_name = "torso_height"

    def __init__(
        self,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        uph_cost_weight: float = 1.0,
        ctrl_cost_weight: float = 0.1,
        impact_cost_weight: float = 0.5e-6,
        impact_cost_range: tuple[float, float] = (-np.inf, 10.0),
        reset_noise_scale: float = 1e-2,
        exclude_current_positions_from_observation: bool = True,
        include_cinert_in_observation: bool = True,
        include_cvel_in_observation: bool = True,
        include_qfrc_actuator_in_observation: bool = True,
        include_cfrc_ext_in_observation: bool = True,
        # warp capacities per env: MuJoCo's HumanoidStandup-v5 (Newton) peaked at 11 contacts and 33
        # constraint rows over 8 x 1000 random steps
        naconmax: int = 32,
        njmax: int = 128,
        **mjx_kwargs: Any,
    ):
        super().__init__(
            "humanoid_standup.xml",
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
        self.uph_cost_weight = uph_cost_weight
        self.ctrl_cost_weight = ctrl_cost_weight
        self.impact_cost_weight = impact_cost_weight
        self.impact_cost_range = impact_cost_range
        self.timestep = float(self.mj_model.opt.timestep)
        self.init_z = float(self.mj_model.qpos0[2])

    def position_metrics(self, qpos: jax.Array) -> dict[str, jax.Array]:
        """``x_position``, ``y_position``, ``z_distance_from_origin`` and ``task_score`` (the height),
        ``[]`` each, of the torso at ``qpos``."""
        return {
            "x_position": qpos[0],
            "y_position": qpos[1],
            "z_distance_from_origin": qpos[2] - self.init_z,
            "task_score": qpos[2],
        }

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        return self._start_from(self.reset_state(key))

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` at ``qpos [nq]``, ``qvel [nv]`` (``MjxEnv.start_state``)."""
        return self._start_from(self.physics_state(qpos, qvel, forward=True))

    def _start_from(self, data: Any) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """The reset's ``(data, obs, metrics)`` from its physics state ``data`` (after a forward pass)."""
        zero = jnp.zeros((), data.qpos.dtype)  # the dtype of the step's metrics: one compiled step
        metrics = {"reward_linup": zero, "reward_quadctrl": zero, "reward_impact": zero}
        return data, self.observation(data), {**metrics, **self.position_metrics(data.qpos)}

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        data = self.physics_step(state.data, action)
        uph = self.uph_cost_weight * data.qpos[2] / self.timestep
        ctrl_cost = self.ctrl_cost_weight * jnp.sum(jnp.square(action))
        impact_cost = self.external_force_cost(data, self.impact_cost_weight, self.impact_cost_range)
        metrics = {"reward_linup": uph, "reward_quadctrl": -ctrl_cost, "reward_impact": -impact_cost}
        reward = uph - ctrl_cost - impact_cost + 1  # Gymnasium's order of the sums
        terminated = jnp.zeros((), bool)
        return data, self.observation(data), reward, terminated, {**metrics, **self.position_metrics(data.qpos)}
