"""What PPO and A2C share: policy and value trained together, by one first-order optimizer, on
one loss

    L = -E[surrogate] + value_coef * E[(V(s) - target)^2] - entropy_coef * E[H(pi(.|s))],

whose surrogate is the likelihood ratio times the advantage, ``r A`` with
``r = pi(a|s) / pi_old(a|s)`` (A2C: its gradient at ``r = 1`` is the policy gradient
``E[A grad log pi]``), or PPO's clipped ``min(r A, clip(r, 1 - eps, 1 + eps) A)``.

The optimizer sees ``{"policy": params, "value": value_params}`` (``joint_params``); its state
lives in ``TrainState.opt_state``, and the parameters stay in ``params`` / ``value_params`` as
for every algorithm. The value network predicts returns as they are, or, with
``normalize_value_targets``, standardised by running statistics of the targets
(``core.standardise_value_targets``): the value loss then stays near 1 whatever the scale of the
rewards, so that it does not swamp the policy's share of the clipped joint gradient.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import optax

from jaxpg import value as value_lib
from jaxpg.algos import core
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env
from jaxpg.rollout import Trajectory


@dataclasses.dataclass(frozen=True)
class ActorCriticConfig(core.GAEConfig):
    """The fields of the joint loss and its advantages, besides GAE's (``core.GAEConfig``).

    Rewards are multiplied by ``reward_scaling`` before advantages and value targets;
    ``value_coef`` and ``entropy_coef`` weigh the value loss and the entropy bonus;
    ``max_grad_norm`` clips the global norm of the joint gradient (0: no clipping);
    ``anneal_lr_iterations`` > 0 decays the learning rate linearly to 0 over that many iterations
    (``learning_rate_schedule``);
    ``normalize_value_targets`` fits the value network to standardised targets
    (``core.standardise_value_targets``);
    ``normalize_rewards`` divides rewards by a running std of the discounted return (with
    ``gamma``), clipped to [-10, 10], before ``reward_scaling`` (``core.normalize_rewards``:
    Stable-Baselines3's ``VecNormalize(norm_reward=True)``, Gymnasium's ``NormalizeReward``).
    """

    value_coef: float = 0.5
    entropy_coef: float = 0.0
    max_grad_norm: float = 0.5
    reward_scaling: float = 1.0
    anneal_lr_iterations: int = 0
    normalize_rewards: bool = False

    TRACED_FIELDS: ClassVar[tuple[str, ...]] = (
        "value_coef",
        "entropy_coef",
        "max_grad_norm",
        "reward_scaling",
        "anneal_lr_iterations",
    )

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.max_grad_norm < 0:
            raise ValueError(f"max_grad_norm must be >= 0 (0: no clipping), got {self.max_grad_norm}")
        if self.anneal_lr_iterations < 0:
            raise ValueError(f"anneal_lr_iterations must be >= 0 (0: constant), got {self.anneal_lr_iterations}")


def learning_rate_schedule(lr: float, config: ActorCriticConfig, steps_per_iteration: int) -> optax.Schedule | float:
    """The learning rate as optax takes it: ``lr``, or its linear decay to 0 over
    ``config.anneal_lr_iterations`` iterations of ``steps_per_iteration`` optimizer steps each.
    ``lr`` and ``config``'s fields may be traced (``core.run_config``; a traced horizon always
    anneals): the schedule is then ``linear_decay``, which rounds as optax's does."""
    anneal = config.anneal_lr_iterations
    if not isinstance(anneal, jax.Array):
        if not anneal:
            return lr
        if not isinstance(lr, jax.Array):
            return optax.linear_schedule(lr, 0.0, anneal * steps_per_iteration)
    return linear_decay(lr, anneal * steps_per_iteration)


def linear_decay(init_value: jax.Array, transition_steps: jax.Array) -> optax.Schedule:
    """``count -> init_value * (1 - min(count, transition_steps) / transition_steps)`` for traced
    ``init_value`` and ``transition_steps`` (``[]``): ``optax.linear_schedule(init_value, 0.0,
    transition_steps)`` written for arrays, its division by the constant number of steps done as
    XLA does it there (``core.divide``)."""

    def schedule(count: jax.Array) -> jax.Array:
        count = jnp.clip(count - 0, 0, transition_steps)
        frac = 1 - core.divide(count, transition_steps)
        return (init_value - 0.0) * (frac**1) + 0.0

    return schedule


def joint_params(ts: TrainState) -> dict[str, Any]:
    """The parameters the joint optimizer sees: ``{"policy": params, "value": value_params}``."""
    return {"policy": ts.params, "value": ts.value_params}


def with_joint_params(ts: TrainState, joint: dict[str, Any], opt_state: Any) -> TrainState:
    """``ts`` with ``joint``'s parameters stored back in their usual places."""
    return ts.replace(params=joint["policy"], value_params=joint["value"], opt_state=opt_state)


def init_state(
    key: jax.Array, env: Env, config: ActorCriticConfig, optimizer: optax.GradientTransformation
) -> TrainState:
    """``core.init_state`` plus ``optimizer``'s state over the joint parameters."""
    ts = core.init_state(key, env, config)
    ts = ts.replace(opt_state=optimizer.init(joint_params(ts)))
    if config.normalize_rewards:
        ts = ts.replace(reward_normalizer=core.RewardNormalizer.create(config.num_envs))
    return ts


def phase_rewards(ts: TrainState, traj: Trajectory) -> tuple[TrainState, Trajectory]:
    """With ``config.normalize_rewards``: ``traj`` with its rewards normalised
    (``core.normalize_rewards``) and ``ts`` with the ``reward_normalizer`` after them; otherwise
    both as they are. The metrics come from the sampled ``traj``, not from this one."""
    if not ts.config.normalize_rewards:
        return ts, traj
    traj, normalizer = core.normalize_trajectory_rewards(ts.reward_normalizer, traj, core.run_config(ts).gamma)
    return ts.replace(reward_normalizer=normalizer), traj


def phase_advantages(ts: TrainState, traj: Trajectory) -> core.Batch:
    """``core.phase_advantages`` on rewards multiplied by ``config.reward_scaling``."""
    scaled = traj.replace(rewards=traj.rewards * core.run_config(ts).reward_scaling)
    return core.phase_advantages(ts, scaled)


def _is_on(eps: Any) -> bool:
    """Whether a clip range turns its clipping on: > 0, or traced (a program clips or not for all its runs)."""
    return not isinstance(eps, int | float) or eps > 0


def loss(
    ts: TrainState,
    joint: dict[str, Any],
    batch: core.Batch,
    clip_eps: float = 0.0,
    value_clip_eps: float = 0.0,
    old_values: jax.Array | None = None,
) -> tuple[jax.Array, dict[str, jax.Array]]:
    """The joint loss (module docstring) on ``batch`` (``[n]`` samples): ``(total [], diagnostics)``.

    Policy term: with ``clip_eps`` > 0 PPO's clipped surrogate ``-E[min(r A, clip(r, 1 -+ eps)
    A)]``, with ``clip_eps`` 0 the plain ``-E[r A]`` (A2C), where
    ``r = exp(log pi(a|s) - log pi_old(a|s))``. Value term: ``E[(V(s) - target)^2]``; with
    ``value_clip_eps`` > 0 the larger of that error and the error of
    ``old_values + clip(V(s) - old_values, -+ value_clip_eps)`` (PPO2's value clipping;
    ``old_values [n]`` are the predictions at sampling time). Entropy term: ``E[H(pi(.|s))]``.
    ``ts``'s run (``core.run_config``) supplies ``value_coef`` and ``entropy_coef``; a traced
    ``clip_eps`` must be ``config.clip_eps``'s (its bounds come from ``core.derived``); means are weighted by
    ``batch.weights``. ``diagnostics``: ``policy_loss``, ``value_loss``, ``entropy``,
    ``approx_kl`` and ``clip_fraction``.
    """
    config = core.run_config(ts)
    w = batch.weights
    dist = ts.policy.dist(joint["policy"], batch.obs)
    log_ratio = ts.policy.dist_log_prob(dist, batch.actions) - batch.log_probs
    ratio = jnp.exp(log_ratio)
    if _is_on(clip_eps):
        if isinstance(clip_eps, int | float):
            low, high = 1.0 - clip_eps, 1.0 + clip_eps
        else:  # traced: PPO's config.clip_eps, whose bounds the host computed (core.derived)
            low, high = core.derived(ts, "1-clip_eps"), core.derived(ts, "1+clip_eps")
        surrogate = jnp.minimum(ratio * batch.advantages, jnp.clip(ratio, low, high) * batch.advantages)
        clipped = (jnp.abs(ratio - 1.0) > clip_eps).astype(ratio.dtype)
    else:
        surrogate = ratio * batch.advantages
        clipped = jnp.zeros_like(ratio)
    policy_loss = -core.weighted_mean(surrogate, w)
    if _is_on(value_clip_eps):
        values = ts.value_fn.apply(joint["value"], batch.obs)
        values_clipped = old_values + jnp.clip(values - old_values, -value_clip_eps, value_clip_eps)
        targets = batch.value_targets
        err = jnp.maximum(jnp.square(values - targets), jnp.square(values_clipped - targets))
        value_loss = core.weighted_mean(err, w)
    else:
        value_loss = value_lib.value_loss(ts.value_fn, joint["value"], batch.obs, batch.value_targets, w)
    entropy = core.weighted_mean(ts.policy.dist_entropy(dist), w)
    total = policy_loss + config.value_coef * value_loss - config.entropy_coef * entropy
    diagnostics = {
        "policy_loss": policy_loss,
        "value_loss": value_loss,
        "entropy": entropy,
        # Schulman's low-variance estimator of KL(pi_old || pi): E[(r - 1) - log r].
        "approx_kl": core.weighted_mean((ratio - 1.0) - log_ratio, w),
        "clip_fraction": core.weighted_mean(clipped, w),
    }
    return total, diagnostics


def gradient_step(
    ts: TrainState,
    optimizer: optax.GradientTransformation,
    joint: dict[str, Any],
    opt_state: Any,
    batch: core.Batch,
    clip_eps: float = 0.0,
    value_clip_eps: float = 0.0,
    old_values: jax.Array | None = None,
) -> tuple[dict[str, Any], Any, dict[str, jax.Array]]:
    """One ``optimizer`` step on ``loss`` (the clipping arguments as there: PPO's; A2C leaves
    them off). Returns the new joint parameters, optimizer state and the loss diagnostics with
    ``loss`` and the pre-clipping ``grad_norm``."""
    grad_fn = jax.value_and_grad(loss, argnums=1, has_aux=True)
    (total, diagnostics), grads = grad_fn(ts, joint, batch, clip_eps, value_clip_eps, old_values)
    updates, opt_state = optimizer.update(grads, opt_state, joint)
    joint = optax.apply_updates(joint, updates)
    return joint, opt_state, {**diagnostics, "loss": total, "grad_norm": optax.tree.norm(grads)}
