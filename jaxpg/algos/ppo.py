"""Proximal Policy Optimization with the clipped surrogate (Schulman et al. 2017).

One iteration:
  1. sample ``num_envs x horizon`` transitions with the stochastic policy (``core.phase_sample``);
  2. scale the rewards by ``reward_scaling``, then GAE(gamma, lambda) advantages and
     lambda-return value targets from the current value function
     (``actor_critic.phase_advantages``);
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
from typing import Any

import jax
import jax.numpy as jnp
import optax

from jaxpg.algos import actor_critic, core
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
    ``value_target`` is ``"gae"`` (lambda-returns) or ``"returns"`` (discounted returns).
    """

    num_envs: int = 32
    horizon: int = 32
    num_epochs: int = 10
    num_minibatches: int = 8
    lr: float = 1e-3
    anneal_lr_iterations: int = 0
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
        if not self.lr > 0 or self.anneal_lr_iterations < 0:
            raise ValueError(
                f"lr must be > 0 and anneal_lr_iterations >= 0, got {self.lr}, {self.anneal_lr_iterations}"
            )
        if not self.clip_eps > 0 or self.value_clip_eps < 0:
            raise ValueError(
                f"clip_eps must be > 0 and value_clip_eps >= 0, got {self.clip_eps}, {self.value_clip_eps}"
            )


PRESETS: dict[str, dict[str, Any]] = {
    # Brax's PPO on MJX Hopper (the reference run in BENCHMARKS.md): 2048 envs, unrolls of 20 steps, 32
    # minibatches x 4 epochs, lr 3e-4, entropy 1e-3, gamma 0.99, reward scaling 10, observation
    # normalisation, no gradient clipping. Brax gathers 8 unrolls of 20 steps per update
    # (batch 512 x 32 minibatches = 16384 unrolls); horizon 160 holds the same samples per update
    # (327,680) and minibatch size (10,240), with GAE running over the 160 steps.
    # One H100, MJX jax impl, seed 0: 205 k env steps/s after a 75 s first block (compile
    # included); mean-policy return 880 at 11.5 M steps, 123 s.
    "brax_hopper": dict(
        num_envs=2048,
        horizon=160,
        num_minibatches=32,
        num_epochs=4,
        lr=3e-4,
        max_grad_norm=0.0,
        entropy_coef=1e-3,
        gamma=0.99,
        gae_lambda=0.95,
        reward_scaling=10.0,
        normalize_observations=True,
        policy_hidden=(32, 32, 32, 32),
        policy_activation="swish",
        value_hidden=(256, 256, 256, 256, 256),
        value_activation="swish",
        network_init="orthogonal",
        eval_envs=128,
        eval_every=10,
    ),
    # The same with unrolls of 20 steps per update (more, smaller updates).
    "brax_hopper_short": dict(
        num_envs=2048,
        horizon=20,
        num_minibatches=32,
        num_epochs=4,
        lr=3e-4,
        max_grad_norm=0.0,
        entropy_coef=1e-3,
        gamma=0.99,
        gae_lambda=0.95,
        reward_scaling=10.0,
        normalize_observations=True,
        policy_hidden=(32, 32, 32, 32),
        policy_activation="swish",
        value_hidden=(256, 256, 256, 256, 256),
        value_activation="swish",
        network_init="orthogonal",
        eval_envs=128,
        eval_every=50,
    ),
    # Solves inverted_pendulum on the CPU: seeds 0 and 1 evaluated at 1000 from iteration 35 to 80
    # (first after 20 iterations, 20 k env steps; tests/test_learning.py).
    "pendulum": dict(
        num_envs=32,
        horizon=32,
        num_minibatches=8,
        num_epochs=10,
        lr=1e-3,
        gamma=0.99,
        gae_lambda=0.95,
        eval_envs=8,
    ),
    # Hopper on one GPU (BENCHMARKS.md: mean-policy return 3000 in a median 50 s on an H100):
    # brax_hopper's networks and losses with 8192 envs x 32 steps in 8 minibatches.
}
# Atari games from pixels (atari_pong): the PPO of the Atari literature (Schulman et al. 2017's
# Atari settings as CleanRL's ppo_atari keeps them: horizon 128, 4 epochs of 4 minibatches, Adam
# 2.5e-4 annealed to 0, clip 0.1, entropy 0.01, value loss 0.5 with value clipping, gradient norm
# 0.5, GAE(0.99, 0.95), orthogonal initialisation) with the Nature network (three convolutions,
# 512 ReLU units) in front of each of the policy and the value function. 16 games rather than 8:
# ALE's vector env steps 16 games about as fast as 8 on a 16-core host. anneal_lr_iterations
# spans 2500 iterations (5.1 M agent steps, 20 M frames).
PRESETS["atari"] = dict(
    num_envs=16,
    horizon=128,
    num_minibatches=4,
    num_epochs=4,
    lr=2.5e-4,
    anneal_lr_iterations=2500,
    clip_eps=0.1,
    value_clip_eps=0.1,
    entropy_coef=0.01,
    value_coef=0.5,
    max_grad_norm=0.5,
    gamma=0.99,
    gae_lambda=0.95,
    **actor_critic.ATARI_NETWORKS,
)
PRESETS["hopper_gpu"] = {
    **PRESETS["brax_hopper"],
    "num_envs": 8192,
    "horizon": 32,
    "num_minibatches": 8,
    "num_epochs": 4,
    "eval_envs": 32,
    "eval_every": 10,
}


def optimizer(config: Config) -> optax.GradientTransformation:
    """Gradient clipping, then Adam with a constant or linearly annealed learning rate.

    The annealing schedule counts optimizer steps: ``num_epochs * num_minibatches`` per iteration.
    """
    lr: Any = config.lr
    if config.anneal_lr_iterations:
        steps = config.anneal_lr_iterations * config.num_epochs * config.num_minibatches
        lr = optax.linear_schedule(config.lr, 0.0, steps)
    return optax.chain(core.clip_gradients(config.max_grad_norm), optax.adam(lr, eps=config.adam_eps))


def learning_rate(config: Config, iteration: jax.Array) -> jax.Array:
    """``[]`` the learning rate at the start of ``iteration`` (0-based)."""
    if not config.anneal_lr_iterations:
        return jnp.asarray(config.lr, jnp.float32)
    frac = jnp.clip(iteration.astype(jnp.float32) / config.anneal_lr_iterations, 0.0, 1.0)
    return config.lr * (1.0 - frac)


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
    batch = actor_critic.phase_advantages(ts, traj)
    ts, diagnostics = phase_epochs(ts, batch, epochs_key)
    # The exact mean KL(pi_old || pi_new) over the batch, as every algorithm reports it.
    kl = core.mean_kl(ts, old.params, ts.params, batch)
    metrics = {**diagnostics, "learning_rate": learning_rate(ts.config, old.iteration)}
    return core.finish_iteration(old, ts, traj, loss=diagnostics["loss"], kl=kl, metrics=metrics)


# The tasks each preset was made for (``jaxpg.algos.preset`` refuses it on others); unnamed: any task.
PRESET_TASKS: dict[str, tuple[str, ...]] = {
    "brax_hopper": ("hopper",),
    "brax_hopper_short": ("hopper",),
    "hopper_gpu": ("hopper",),
    "pendulum": ("inverted_pendulum",),
    "atari": ("atari_pong", "pong"),
}
