"""CartPole with the semantics of Gymnasium's ``CartPole-v1``, in pure JAX (no MuJoCo).

The cart-pole equations of Barto, Sutton and Anderson (1983) in the corrected form of Florian (2007),
integrated with explicit Euler at ``tau = 0.02`` s, with Gymnasium's constants. State and observation
``[4]``: cart position ``x``, cart velocity, pole angle ``theta`` (0 upright), pole angular velocity.
Actions are discrete: 0 pushes the cart left, 1 right, with a force of 10 N. Reward 1 on every step,
the terminating one included (v1's default). The episode terminates when ``|x| > 2.4`` or
``|theta| > 12`` degrees; 500-step limit. Reset: every state entry uniform in ``[-0.05, 0.05]``.
The task score is the number of steps so far, which at the end of an episode is its return.

An action is an integer scalar; a float or a non-scalar raises ``ValueError`` when ``step`` is
traced. An integer outside ``{0, 1}`` (e.g. 7 or -1) is *not* a push in either direction: as in
every discrete jaxpg task (``jaxpg.envs.base``), the step is not taken (the cart-pole keeps its
state), the episode ends as ``terminated`` with reward 0 and a zeroed observation, and
``metrics["invalid_action"]`` is 1. Integer actions cannot be NaN.
"""

from __future__ import annotations

import math
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from jaxpg.envs.base import Env, State


@struct.dataclass
class CartPoleData:
    """Physics state of one cart-pole: ``state [4] = (x, x_dot, theta, theta_dot)``."""

    state: jax.Array


class CartPole(Env):
    """Pure-JAX CartPole; see the module docstring for the task definition."""

    name = "cartpole"
    discrete = True
    action_size = 2
    observation_size = 4
    task_score_name = "steps"

    gravity = 9.8
    masscart = 1.0
    masspole = 0.1
    length = 0.5  # half the pole's length
    force_mag = 10.0
    tau = 0.02
    theta_threshold = 12 * 2 * math.pi / 360
    x_threshold = 2.4

    def __init__(self, max_episode_steps: int = 500, reset_bound: float = 0.05):
        self.max_episode_steps = max_episode_steps
        self.reset_bound = reset_bound
        self.dt = self.tau
        self.total_mass = self.masspole + self.masscart
        self.polemass_length = self.masspole * self.length

    def dynamics(self, state: jax.Array, action: jax.Array) -> jax.Array:
        """One Euler step of ``state [4]`` under the discrete ``action`` (0 or 1; ``Env.step``
        undoes steps with any other value); same operation order as Gymnasium, so that float64
        results agree to the last bit but for sin/cos."""
        x, x_dot, theta, theta_dot = state[0], state[1], state[2], state[3]
        force = jnp.where(action == 1, self.force_mag, -self.force_mag).astype(state.dtype)
        costheta, sintheta = jnp.cos(theta), jnp.sin(theta)
        temp = (force + self.polemass_length * jnp.square(theta_dot) * sintheta) / self.total_mass
        thetaacc = (self.gravity * sintheta - costheta * temp) / (
            self.length * (4.0 / 3.0 - self.masspole * jnp.square(costheta) / self.total_mass)
        )
        xacc = temp - self.polemass_length * thetaacc * costheta / self.total_mass
        return jnp.stack(
            [
                x + self.tau * x_dot,
                x_dot + self.tau * xacc,
                theta + self.tau * theta_dot,
                theta_dot + self.tau * thetaacc,
            ]
        )

    def _reset(self, key: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        b = self.reset_bound
        state = jax.random.uniform(key, (4,), minval=-b, maxval=b)
        return CartPoleData(state=state), state, {"task_score": jnp.zeros((), jnp.float32)}

    def _step(self, state: State, action: jax.Array) -> tuple[Any, jax.Array, jax.Array, jax.Array, dict]:
        new = self.dynamics(state.data.state, action)
        x, theta = new[0], new[2]
        terminated = (jnp.abs(x) > self.x_threshold) | (jnp.abs(theta) > self.theta_threshold)
        reward = jnp.ones((), jnp.float32)
        metrics = {"task_score": state.info["step"].astype(jnp.float32) + 1.0}
        return CartPoleData(state=new), new, reward, terminated, metrics
