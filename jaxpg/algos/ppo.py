"""Proximal Policy Optimization with the clipped surrogate (Schulman et al. 2017).

One iteration:
  1. sample ``num_envs x horizon`` transitions with the stochastic policy (``core.phase_sample``);
  2. scale the rewards by ``reward_scaling``, then GAE(gamma, lambda) advantages and
     lambda-return value targets from the current value function
     (``actor_critic.phase_advantages``), standardised with ``normalize_value_targets``
     (``core.standardise_value_targets``);
  3. ``num_epochs`` passes over the batch, each in a fresh random order cut into
     ``num_minibatches`` minibatches; on each minibatch one optimizer step on the joint loss
     (eq. 9 of the paper)

         L = -E[min(r A, clip(r, 1 - eps, 1 + eps) A)] + value_coef * L_V - entropy_coef * H,
         r = pi(a|s) / pi_old(a|s),

     where ``L_V`` is the mean squared error to the value targets (optionally clipped around the
     old predictions), and one optax optimizer (gradient clipping, then Adam) updates policy and
     value parameters together (``actor_critic.gradient_step``, shared with A2C);
  4. reject the update if anything became non-finite or left the trust region, update
     observation statistics (``core.finish_iteration``).

Both scans (epochs, minibatches) run inside ``jit``.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import optax

from jaxpg.algos import actor_critic, core, presets
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env


@dataclasses.dataclass(frozen=True)
class Config(actor_critic.ActorCriticConfig):
    """PPO hyperparameters (defaults: a quick CPU setting; ``PRESETS`` holds larger ones).

    Optimisation: ``num_epochs`` passes of ``num_minibatches`` minibatches of
    ``num_envs * horizon / num_minibatches`` samples; Adam with learning rate ``lr`` (decayed
    linearly to 0 over ``anneal_lr_iterations`` iterations when that is > 0) and epsilon
    ``adam_eps``, after clipping the global gradient norm to ``max_grad_norm`` (0: no clipping).
    Loss: ``clip_eps`` is the ratio clip; ``value_clip_eps`` > 0 clips the value prediction to
    within that distance of the sampling-time prediction (PPO2's value clipping; 0: off);
    ``value_coef`` and ``entropy_coef`` weigh the value loss and the entropy bonus.
    Returns: rewards are multiplied by ``reward_scaling`` before GAE(``gamma``, ``gae_lambda``);
    ``value_target`` is ``"gae"`` (lambda-returns) or ``"returns"`` (discounted returns);
    ``normalize_value_targets`` trains the value network on standardised targets (the value loss,
    and ``value_clip_eps``, are then in standardised units).
    """

    num_envs: int = 32
    horizon: int = 32
    num_epochs: int = 10
    num_minibatches: int = 8
    lr: float = 1e-3
    adam_eps: float = 1e-5
    max_grad_norm: float = 0.5
    clip_eps: float = 0.2
    value_clip_eps: float = 0.0

    @property
    def minibatch_size(self) -> int:
        return self.samples_per_iteration // self.num_minibatches

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.num_epochs < 1 or self.num_minibatches < 1:
            raise ValueError(
                f"num_epochs and num_minibatches must be >= 1, got {self.num_epochs}, {self.num_minibatches}"
            )
        if self.samples_per_iteration % self.num_minibatches:
            raise ValueError(
                f"num_envs {self.num_envs} x horizon {self.horizon} = {self.samples_per_iteration} samples "
                f"do not split into {self.num_minibatches} equal minibatches"
            )
        if not self.lr > 0:
            raise ValueError(f"lr must be > 0, got {self.lr}")
        if not self.clip_eps > 0 or self.value_clip_eps < 0:
            raise ValueError(
                f"clip_eps must be > 0 and value_clip_eps >= 0, got {self.clip_eps}, {self.value_clip_eps}"
            )


# Named Config overrides: a read-only view of this algorithm's rows of ``presets.TABLE``.
PRESETS = presets.by_algorithm("ppo")


def learning_rate_schedule(config: Config) -> optax.Schedule | float:
    """``actor_critic.learning_rate_schedule`` counting optimizer steps: ``num_epochs *
    num_minibatches`` per iteration."""
    return actor_critic.learning_rate_schedule(config.lr, config, config.num_epochs * config.num_minibatches)


def optimizer(config: Config) -> optax.GradientTransformation:
    """Gradient clipping, then Adam with ``learning_rate_schedule``."""
    return optax.chain(
        core.clip_gradients(config.max_grad_norm), optax.adam(learning_rate_schedule(config), eps=config.adam_eps)
    )


def learning_rate(config: Config, iteration: jax.Array) -> jax.Array:
    """``[]`` the learning rate at the start of ``iteration`` (0-based): the schedule's value at
    that iteration's first optimizer step."""
    schedule = learning_rate_schedule(config)
    if not callable(schedule):
        return jnp.asarray(schedule, jnp.float32)
    return jnp.asarray(schedule(iteration * config.num_epochs * config.num_minibatches), jnp.float32)


def init(key: jax.Array, env: Env, config: Config) -> TrainState:
    """A fresh ``TrainState``: networks, the joint Adam state, env batch."""
    return actor_critic.init_state(key, env, config, optimizer(config))


def phase_epochs(ts: TrainState, batch: core.Batch, key: jax.Array) -> tuple[TrainState, dict[str, jax.Array]]:
    """``num_epochs`` passes of ``num_minibatches`` clipped-surrogate steps, each epoch in a fresh
    random order. Returns the state with the new parameters and optimizer state, and the
    diagnostics of ``actor_critic.gradient_step`` averaged over all steps."""
    config = ts.config
    opt = optimizer(config)
    n = config.samples_per_iteration
    old_values = ts.value_fn.apply(ts.value_params, batch.obs)

    def minibatch(carry: tuple, idx: jax.Array) -> tuple[tuple, dict[str, jax.Array]]:
        joint, opt_state = carry
        mb = jax.tree.map(lambda x: x[idx], batch)
        joint, opt_state, diagnostics = actor_critic.gradient_step(
            ts, opt, joint, opt_state, mb, config.clip_eps, config.value_clip_eps, old_values[idx]
        )
        return (joint, opt_state), diagnostics

    def epoch(carry: tuple, epoch_key: jax.Array) -> tuple[tuple, dict[str, jax.Array]]:
        order = jax.random.permutation(epoch_key, n).reshape(config.num_minibatches, config.minibatch_size)
        return jax.lax.scan(minibatch, carry, order)

    (joint, opt_state), diagnostics = jax.lax.scan(
        epoch, (actor_critic.joint_params(ts), ts.opt_state), jax.random.split(key, config.num_epochs)
    )
    return actor_critic.with_joint_params(ts, joint, opt_state), jax.tree.map(jnp.mean, diagnostics)


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One PPO iteration (module docstring); pure, jittable, vmappable over seeds."""
    old = ts
    ts, traj, key = core.phase_sample(ts)
    epochs_key, _ = jax.random.split(key)
    ts, learning_traj = actor_critic.phase_rewards(ts, traj)
    batch = actor_critic.phase_advantages(ts, learning_traj)
    ts, fit_batch = core.standardise_value_targets(ts, batch)
    ts, diagnostics = phase_epochs(ts, fit_batch, epochs_key)
    # The exact mean KL(pi_old || pi_new) over the batch, as every algorithm reports it.
    kl = core.mean_kl(ts, old.params, ts.params, batch)
    metrics = {**diagnostics, "learning_rate": learning_rate(ts.config, old.iteration)}
    return core.finish_iteration(old, ts, traj, loss=diagnostics["loss"], kl=kl, metrics=metrics)
