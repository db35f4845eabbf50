"""Proximal Policy Optimization with the clipped surrogate (Schulman et al. 2017).

One iteration:
  1. sample ``num_envs x horizon`` transitions with the stochastic policy (``core.phase_sample``);
  2. scale the rewards by ``reward_scaling``, then GAE(gamma, lambda) advantages and
     lambda-return value targets from the current value function
     (``actor_critic.phase_advantages``), standardised with ``normalize_value_targets``
     (``core.standardise_value_targets``);
  3. ``num_epochs`` passes over the batch, each in a fresh random order cut into
     ``num_minibatches`` minibatches (with ``recompute_advantages``, every pass after the first
     takes its advantages and value targets afresh from the value network as the previous
     passes left it); on each minibatch (its advantages standardised on their own with
     ``normalize_minibatch_advantages``) one optimizer step on the joint loss (eq. 9 of the
     paper)

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
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import optax

from jaxpg import returns
from jaxpg.algos import actor_critic, core, presets
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env
from jaxpg.rollout import Trajectory


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
    Advantages: ``normalize_advantages`` standardises them over the batch;
    ``normalize_minibatch_advantages`` standardises each minibatch's on their own before its
    step, as Stable-Baselines3, CleanRL, Tianshou and Brax do (population std, epsilon 1e-8);
    ``recompute_advantages`` recomputes advantages and value targets (GAE from the same
    samples) with the current value network before every epoch after the first, as Tianshou's
    ``recompute_advantage`` does; the value-target statistics absorb each batch once, and value
    clipping then takes the epoch's starting predictions as the old ones.
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
    normalize_minibatch_advantages: bool = False
    recompute_advantages: bool = False

    TRACED_FIELDS: ClassVar[tuple[str, ...]] = ("lr", "adam_eps", "clip_eps", "value_clip_eps")

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


def run_optimizer(ts: TrainState) -> optax.GradientTransformation:
    """``optimizer`` of ``ts``'s run: its numbers read through ``core.run_config`` (traced when
    ``ts`` carries hparams), its structure (clipping on or off, a schedule or not) from ``ts.config``."""
    if not core.is_traced(ts):
        return optimizer(ts.config)
    run = core.run_config(ts)
    clip = optax.clip_by_global_norm(run.max_grad_norm) if ts.config.max_grad_norm > 0 else optax.identity()
    return optax.chain(clip, optax.adam(learning_rate_schedule(run), eps=run.adam_eps))


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


def epoch_batch(ts: TrainState, joint: dict[str, Any], traj: Trajectory) -> core.Batch:
    """``recompute_advantages``' batch for an epoch: ``traj``'s (the learning trajectory, rewards
    as GAE sees them before scaling) advantages and value targets from the value network in
    ``joint``, the targets standardised by ``ts.value_stats`` as they stand. ``[N, ...]``."""
    now = ts.replace(value_params=joint["value"])
    return core.standardised_targets(now, actor_critic.phase_advantages(now, traj))


def minibatch_advantages(batch: core.Batch) -> core.Batch:
    """``batch`` (one minibatch, ``[n]`` samples) with its advantages standardised over its valid
    samples (``returns.normalize``)."""
    return batch.replace(advantages=returns.normalize(batch.advantages, mask=batch.weights))


def phase_epochs(
    ts: TrainState, batch: core.Batch, key: jax.Array, traj: Trajectory | None = None
) -> tuple[TrainState, dict[str, jax.Array]]:
    """``num_epochs`` passes of ``num_minibatches`` clipped-surrogate steps, each epoch in a fresh
    random order. ``batch`` (``[N, ...]``) is what the first epoch trains on; with
    ``recompute_advantages`` each later epoch trains on ``epoch_batch`` of ``traj`` (required
    then). Returns the state with the new parameters and optimizer state, and the diagnostics of
    ``actor_critic.gradient_step`` averaged over all steps."""
    config = ts.config
    if config.recompute_advantages and traj is None:
        raise ValueError("recompute_advantages needs the learning trajectory (traj)")
    opt = run_optimizer(ts)
    run = core.run_config(ts)
    clip_eps = run.clip_eps
    value_clip_eps = run.value_clip_eps if config.value_clip_eps > 0 else 0.0
    n = config.samples_per_iteration
    old_values = ts.value_fn.apply(ts.value_params, batch.obs)

    def epoch(carry: tuple, inputs: tuple[jax.Array, jax.Array]) -> tuple[tuple, dict[str, jax.Array]]:
        epoch_key, index = inputs
        data, data_old_values = batch, old_values
        if config.recompute_advantages:
            joint = carry[0]
            first = index == 0
            data = jax.tree.map(lambda a, b: jnp.where(first, a, b), batch, epoch_batch(ts, joint, traj))
            data_old_values = jnp.where(first, old_values, ts.value_fn.apply(joint["value"], batch.obs))

        def minibatch(carry: tuple, idx: jax.Array) -> tuple[tuple, dict[str, jax.Array]]:
            joint, opt_state = carry
            mb = jax.tree.map(lambda x: x[idx], data)
            if config.normalize_minibatch_advantages:
                mb = minibatch_advantages(mb)
            joint, opt_state, diagnostics = actor_critic.gradient_step(
                ts, opt, joint, opt_state, mb, clip_eps, value_clip_eps, data_old_values[idx]
            )
            return (joint, opt_state), diagnostics

        order = jax.random.permutation(epoch_key, n).reshape(config.num_minibatches, config.minibatch_size)
        return jax.lax.scan(minibatch, carry, order)

    epochs = (jax.random.split(key, config.num_epochs), jnp.arange(config.num_epochs))
    (joint, opt_state), diagnostics = jax.lax.scan(epoch, (actor_critic.joint_params(ts), ts.opt_state), epochs)
    return actor_critic.with_joint_params(ts, joint, opt_state), jax.tree.map(jnp.mean, diagnostics)


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One PPO iteration (module docstring); pure, jittable, vmappable over seeds."""
    old = ts
    ts, traj, key = core.phase_sample(ts)
    epochs_key, _ = jax.random.split(key)
    ts, learning_traj = actor_critic.phase_rewards(ts, traj)
    batch = actor_critic.phase_advantages(ts, learning_traj)
    ts, fit_batch = core.standardise_value_targets(ts, batch)
    ts, diagnostics = phase_epochs(ts, fit_batch, epochs_key, learning_traj)
    # The exact mean KL(pi_old || pi_new) over the batch, as every algorithm reports it.
    kl = core.mean_kl(ts, old.params, ts.params, batch)
    metrics = {**diagnostics, "learning_rate": learning_rate(core.run_config(ts), old.iteration)}
    return core.finish_iteration(old, ts, traj, loss=diagnostics["loss"], kl=kl, metrics=metrics)
