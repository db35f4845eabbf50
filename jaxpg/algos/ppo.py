"""Proximal Policy Optimization with the clipped surrogate (Schulman et al. 2017).

One iteration:
  1. sample ``num_envs x horizon`` transitions with the stochastic policy (``npg.phase_sample``);
  2. scale the rewards by ``reward_scaling``, then GAE(gamma, lambda) advantages and
     lambda-return value targets from the current value function (``npg.phase_advantages``);
  3. ``num_epochs`` passes over the batch, each in a fresh random order cut into
     ``num_minibatches`` minibatches; on each minibatch one optimizer step on the joint loss
     (eq. 9 of the paper)

         L = -E[min(r A, clip(r, 1 - eps, 1 + eps) A)] + value_coef * L_V - entropy_coef * H,
         r = pi(a|s) / pi_old(a|s),

     where ``L_V`` is the mean squared error to the value targets (optionally clipped around the
     old predictions), and one optax optimizer (gradient clipping, then Adam) updates policy and
     value parameters together;
  4. reject the update if anything became non-finite, update observation statistics
     (``npg.finish_iteration``).

Both scans (epochs, minibatches) run inside ``jit``. The optimizer state covers
``{"policy": params, "value": value_params}`` and lives in ``TrainState.opt_state``; the
parameters themselves stay in ``params`` / ``value_params`` as for every algorithm. The pieces an
actor-critic with a joint optimizer needs (``joint_params``, ``init_actor_critic``, ``loss``,
``gradient_step``) are reused by ``jaxpg.algos.a2c``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import optax

from jaxpg import value as value_lib
from jaxpg.algos import common, npg
from jaxpg.algos.common import TrainState
from jaxpg.envs import Env
from jaxpg.rollout import Trajectory


@dataclasses.dataclass(frozen=True)
class Config(common.BaseConfig):
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
    ``sample_budget`` > 0 caps the valid samples in episodic sampling (see ``npg``).
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
    value_coef: float = 0.5
    entropy_coef: float = 0.0
    gae_lambda: float = 0.95
    normalize_advantages: bool = True
    reward_scaling: float = 1.0
    value_target: str = "gae"
    sample_budget: int = 0

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
        if not self.clip_eps > 0 or self.value_clip_eps < 0 or self.max_grad_norm < 0:
            raise ValueError("clip_eps must be > 0, value_clip_eps >= 0 and max_grad_norm >= 0")
        validate_returns(self)


def validate_returns(config: Any) -> None:
    """Checks of the fields ``npg.phase_advantages`` reads (shared with ``a2c``)."""
    if not 0 <= config.gae_lambda <= 1:
        raise ValueError(f"gae_lambda must be in [0, 1], got {config.gae_lambda}")
    if config.value_target not in ("gae", "returns"):
        raise ValueError(f"value_target must be 'gae' or 'returns', got {config.value_target!r}")
    if config.sample_budget < 0:
        raise ValueError(f"sample_budget must be >= 0, got {config.sample_budget}")


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
        policy_init="orthogonal",
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
        policy_init="orthogonal",
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
PRESETS["hopper_gpu"] = {
    **PRESETS["brax_hopper"],
    "num_envs": 8192,
    "horizon": 32,
    "num_minibatches": 8,
    "num_epochs": 4,
    "eval_envs": 32,
    "eval_every": 10,
}


# ---------------------------------------------------------------------------------------------
# Pieces shared by actor-critics that optimise policy and value with one optimizer (PPO, A2C).


def joint_params(ts: TrainState) -> dict[str, Any]:
    """The parameters the joint optimizer sees: ``{"policy": params, "value": value_params}``."""
    return {"policy": ts.params, "value": ts.value_params}


def with_joint_params(ts: TrainState, joint: dict[str, Any], opt_state: Any) -> TrainState:
    """``ts`` with ``joint``'s parameters stored back in their usual places."""
    return ts.replace(params=joint["policy"], value_params=joint["value"], opt_state=opt_state)


def init_actor_critic(key: jax.Array, env: Env, config: Any, optimizer: optax.GradientTransformation) -> TrainState:
    """``common.init_common`` plus ``optimizer``'s state over the joint parameters."""
    ts = common.init_common(key, env, config)
    return ts.replace(opt_state=optimizer.init(joint_params(ts)))


clip_gradients = common.clip_gradients
weighted_mean = common.weighted_mean


def loss(
    ts: TrainState,
    joint: dict[str, Any],
    batch: npg.Batch,
    old_values: jax.Array | None,
    clip_eps: float | None,
    value_clip_eps: float | None,
) -> tuple[jax.Array, dict[str, jax.Array]]:
    """The actor-critic loss on ``batch`` (``[n]`` samples): ``(total [], diagnostics)``.

    Policy term: PPO's clipped surrogate ``-E[min(r A, clip(r, 1 -+ eps) A)]`` with
    ``r = exp(log pi(a|s) - log pi_old(a|s))``, or with ``clip_eps=None`` the plain
    ``-E[r A]``, whose gradient at ``r = 1`` is the policy gradient ``-E[A grad log pi]`` (A2C).
    Value term: ``value_coef * E[(V(s) - target)^2]``; with ``value_clip_eps`` the larger of that
    error and the error of ``old_values + clip(V(s) - old_values, -+ value_clip_eps)``.
    Entropy term: ``-entropy_coef * E[H(pi(.|s))]``. ``ts.config`` supplies the coefficients;
    means are weighted by ``batch.weights``.
    """
    config = ts.config
    w = batch.weights
    dist = ts.policy.dist(joint["policy"], batch.obs)
    log_ratio = ts.policy.dist_log_prob(dist, batch.actions) - batch.log_probs
    ratio = jnp.exp(log_ratio)
    if clip_eps is None:
        surrogate = ratio * batch.advantages
        clipped = jnp.zeros_like(ratio)
    else:
        surrogate = jnp.minimum(
            ratio * batch.advantages, jnp.clip(ratio, 1.0 - clip_eps, 1.0 + clip_eps) * batch.advantages
        )
        clipped = (jnp.abs(ratio - 1.0) > clip_eps).astype(ratio.dtype)
    policy_loss = -weighted_mean(surrogate, w)
    values = ts.value_fn.apply(joint["value"], batch.obs)
    if value_clip_eps:
        values_clipped = old_values + jnp.clip(values - old_values, -value_clip_eps, value_clip_eps)
        targets = batch.value_targets
        err = jnp.maximum(jnp.square(values - targets), jnp.square(values_clipped - targets))
        value_loss = weighted_mean(err, w)
    else:
        value_loss = value_lib.value_loss(ts.value_fn, joint["value"], batch.obs, batch.value_targets, w)
    entropy = weighted_mean(ts.policy.dist_entropy(dist), w)
    total = policy_loss + config.value_coef * value_loss - config.entropy_coef * entropy
    diagnostics = {
        "policy_loss": policy_loss,
        "value_loss": value_loss,
        "entropy": entropy,
        # Schulman's low-variance estimator of KL(pi_old || pi): E[(r - 1) - log r].
        "approx_kl": weighted_mean((ratio - 1.0) - log_ratio, w),
        "clip_fraction": weighted_mean(clipped, w),
    }
    return total, diagnostics


def gradient_step(
    ts: TrainState,
    optimizer: optax.GradientTransformation,
    joint: dict[str, Any],
    opt_state: Any,
    batch: npg.Batch,
    old_values: jax.Array | None,
    clip_eps: float | None,
    value_clip_eps: float | None,
) -> tuple[dict[str, Any], Any, dict[str, jax.Array]]:
    """One ``optimizer`` step on ``loss``; returns new joint params, optimizer state and the
    loss diagnostics (with ``loss`` and the pre-clipping ``grad_norm``)."""
    grad_fn = jax.value_and_grad(loss, argnums=1, has_aux=True)
    (total, diagnostics), grads = grad_fn(ts, joint, batch, old_values, clip_eps, value_clip_eps)
    updates, opt_state = optimizer.update(grads, opt_state, joint)
    joint = optax.apply_updates(joint, updates)
    return joint, opt_state, {**diagnostics, "loss": total, "grad_norm": common.tree_norm(grads)}


# ---------------------------------------------------------------------------------------------
# PPO.


def optimizer(config: Config) -> optax.GradientTransformation:
    """Gradient clipping, then Adam with a constant or linearly annealed learning rate.

    The annealing schedule counts optimizer steps: ``num_epochs * num_minibatches`` per iteration.
    """
    lr: Any = config.lr
    if config.anneal_lr_iterations:
        steps = config.anneal_lr_iterations * config.num_epochs * config.num_minibatches
        lr = optax.linear_schedule(config.lr, 0.0, steps)
    return optax.chain(clip_gradients(config.max_grad_norm), optax.adam(lr, eps=config.adam_eps))


def learning_rate(config: Config, iteration: jax.Array) -> jax.Array:
    """``[]`` the learning rate at the start of ``iteration`` (0-based)."""
    if not config.anneal_lr_iterations:
        return jnp.asarray(config.lr, jnp.float32)
    frac = jnp.clip(iteration.astype(jnp.float32) / config.anneal_lr_iterations, 0.0, 1.0)
    return config.lr * (1.0 - frac)


def init(key: jax.Array, env: Env, config: Config) -> TrainState:
    """A fresh ``TrainState``: networks, the joint Adam state, env batch."""
    return init_actor_critic(key, env, config, optimizer(config))


def phase_advantages(ts: TrainState, traj: Trajectory) -> npg.Batch:
    """``npg.phase_advantages`` on rewards multiplied by ``reward_scaling``."""
    scaled = traj.replace(rewards=traj.rewards * ts.config.reward_scaling)
    return npg.phase_advantages(ts, scaled)


def phase_epochs(ts: TrainState, batch: npg.Batch, key: jax.Array) -> tuple[TrainState, dict[str, jax.Array]]:
    """``num_epochs`` passes of ``num_minibatches`` clipped-surrogate steps, each epoch in a fresh
    random order. Returns the state with the new parameters and optimizer state, and the
    diagnostics of ``gradient_step`` averaged over all steps."""
    config = ts.config
    opt = optimizer(config)
    n = config.samples_per_iteration
    old_values = ts.value_fn.apply(ts.value_params, batch.obs)
    value_clip_eps = config.value_clip_eps or None

    def minibatch(carry: tuple, idx: jax.Array) -> tuple[tuple, dict[str, jax.Array]]:
        joint, opt_state = carry
        mb = jax.tree.map(lambda x: x[idx], batch)
        joint, opt_state, diagnostics = gradient_step(
            ts, opt, joint, opt_state, mb, old_values[idx], config.clip_eps, value_clip_eps
        )
        return (joint, opt_state), diagnostics

    def epoch(carry: tuple, epoch_key: jax.Array) -> tuple[tuple, dict[str, jax.Array]]:
        order = jax.random.permutation(epoch_key, n).reshape(config.num_minibatches, config.minibatch_size)
        return jax.lax.scan(minibatch, carry, order)

    (joint, opt_state), diagnostics = jax.lax.scan(
        epoch, (joint_params(ts), ts.opt_state), jax.random.split(key, config.num_epochs)
    )
    return with_joint_params(ts, joint, opt_state), jax.tree.map(jnp.mean, diagnostics)


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One PPO iteration (module docstring); pure, jittable, vmappable over seeds."""
    old = ts
    ts, traj, key = npg.phase_sample(ts)
    epochs_key, _ = jax.random.split(key)
    batch = phase_advantages(ts, traj)
    ts, diagnostics = phase_epochs(ts, batch, epochs_key)
    metrics = {
        **diagnostics,
        # The exact mean KL(pi_old || pi_new) over the batch, as NPG and TRPO report it.
        "kl": npg.mean_kl(ts, old.params, ts.params, batch),
        "learning_rate": learning_rate(ts.config, old.iteration),
    }
    return npg.finish_iteration(old, ts, traj, diagnostics["loss"], metrics)
