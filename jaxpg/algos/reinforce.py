"""REINFORCE (Williams 1992): the Monte-Carlo policy gradient, without a critic.

One iteration:
  1. sample ``num_envs x horizon`` transitions (by default *episodic*: every env runs one episode
     of at most ``horizon`` steps; ``core.phase_sample``);
  2. Monte-Carlo discounted returns ``G_t = sum_k gamma^k r_{t+k}`` within each episode, with no
     bootstrapping, then normalised (``return_normalization``):
       ``"episode"``: by the mean and std of their own episode (Kokoyi's CartPole, MinPy's Pong,
       Karpathy's "Pong from pixels"), ``"batch"``: over all valid samples, ``"none"``: as they
       are (the Gymnasium tutorial);
  3. one optimizer step (Adam or AdamW, after optional gradient clipping) on

         L = -E[G^_t log pi(a_t | s_t)] - entropy_coef * E[H(pi(. | s_t))],

     the means taken over the valid samples of the batch (Williams' eq. for the episodic case,
     with the batch mean in place of a sum over one episode: with Adam the scale does not matter);
  4. reject non-finite updates, update observation statistics (``core.finish_iteration``).

No value function is learned: ``TrainState.value_params`` is ``{}``. The returns of an episode
cut by ``horizon`` (or, in continuing sampling, by the end of the batch) are those of the part
that was sampled; choose ``horizon`` >= the env's episode limit to avoid that bias.
``jaxpg.algos.vpg`` adds a learned baseline to the same pieces.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import optax

from jaxpg import returns
from jaxpg.algos import core, presets
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env
from jaxpg.rollout import Trajectory

RETURN_NORMALIZATIONS = ("episode", "batch", "none")


@dataclasses.dataclass(frozen=True)
class Config(core.BaseConfig):
    """REINFORCE hyperparameters (defaults: a quick CPU setting for ``cartpole``).

    ``optimizer`` is ``"adam"`` or ``"adamw"`` (decoupled ``weight_decay``; PyTorch's AdamW
    default 0.01) with learning rate ``lr``; ``max_grad_norm`` > 0 clips the global gradient norm
    first (0: off). ``return_normalization`` is one of ``"episode"``, ``"batch"``, ``"none"``
    (module docstring); ``entropy_coef`` weighs an entropy bonus.
    """

    num_envs: int = 32
    horizon: int = 500
    sampling: str = "episodic"
    gamma: float = 0.99
    policy_hidden: tuple[int, ...] = (64, 64)
    optimizer: str = "adam"
    lr: float = 1e-2
    weight_decay: float = 0.01
    return_normalization: str = "episode"
    entropy_coef: float = 0.0
    max_grad_norm: float = 0.0

    TRACED_FIELDS: ClassVar[tuple[str, ...]] = ("lr", "weight_decay", "entropy_coef", "max_grad_norm")

    # REINFORCE has no value function (command lines offer no flag for these).
    UNUSED_FIELDS: ClassVar[tuple[str, ...]] = ("value_hidden", "value_activation", "normalize_value_targets")
    FIELD_CHOICES: ClassVar[dict[str, tuple[str, ...]]] = {"optimizer": ("adam", "adamw")}

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.optimizer not in ("adam", "adamw"):
            raise ValueError(f"optimizer must be 'adam' or 'adamw', got {self.optimizer!r}")
        if not self.lr > 0:
            raise ValueError(f"lr must be > 0, got {self.lr}")
        if self.weight_decay < 0 or self.max_grad_norm < 0 or self.entropy_coef < 0:
            raise ValueError("weight_decay, max_grad_norm and entropy_coef must be >= 0")
        if self.return_normalization not in RETURN_NORMALIZATIONS:
            raise ValueError(
                f"return_normalization must be one of {', '.join(RETURN_NORMALIZATIONS)}, "
                f"got {self.return_normalization!r}"
            )


# Named Config overrides: a read-only view of this algorithm's rows of ``presets.TABLE``.
PRESETS = presets.by_algorithm("reinforce")


def optimizer(config: Config, structure: Config | None = None) -> optax.GradientTransformation:
    """Optional global-norm clipping, then Adam or AdamW with a constant learning rate.
    ``config``'s numbers may be traced (``core.run_config``); ``structure`` (default ``config``)
    then says whether to clip."""
    structure = config if structure is None else structure
    if config.optimizer == "adamw":
        opt = optax.adamw(config.lr, weight_decay=config.weight_decay)
    else:
        opt = optax.adam(config.lr)
    clip = optax.clip_by_global_norm(config.max_grad_norm) if structure.max_grad_norm > 0 else optax.identity()
    return optax.chain(clip, opt)


def init(key: jax.Array, env: Env, config: Config) -> TrainState:
    """A fresh ``TrainState``: policy, its optimizer state, env batch; no value function."""
    ts = core.init_state(key, env, config, optimizer=optimizer(config))
    return ts.replace(value_params={}, value_opt_state=())


def normalized_returns(traj: Trajectory, gamma: float, normalization: str) -> jax.Array:
    """Monte-Carlo discounted returns of ``traj`` normalised as ``normalization`` says: ``[T, B]``.

    Statistics use only the steps where ``traj.valid`` is set; the others come out as 0.
    """
    g = returns.discounted_returns(traj.rewards, traj.terminated, traj.truncated, gamma)
    if normalization == "episode":
        return returns.normalize_per_episode(g, traj.terminated, traj.truncated, traj.valid)
    if normalization == "batch":
        return returns.normalize(g, mask=traj.valid)
    return jnp.where(traj.valid > 0, g, 0.0)


def phase_returns(ts: TrainState, traj: Trajectory) -> core.Batch:
    """The flat training batch whose ``advantages`` (and ``value_targets``) are the normalised
    returns; observations normalised with the statistics the batch was sampled with."""
    g = normalized_returns(traj, core.run_config(ts).gamma, ts.config.return_normalization)
    batch = core.Batch(
        obs=ts.obs_stats.normalize(traj.obs),
        actions=traj.actions,
        log_probs=traj.log_probs,
        advantages=g,
        value_targets=g,
        weights=traj.valid,
    )
    return core.flatten_batch(batch)


def loss(ts: TrainState, params: Any, batch: core.Batch) -> tuple[jax.Array, dict[str, jax.Array]]:
    """``-E[A log pi(a|s)] - entropy_coef * E[H]`` over the weighted batch ``[N]``:
    ``(total [], {"policy_loss", "entropy"})``. ``A`` is ``batch.advantages``, held constant."""
    dist = ts.policy.dist(params, batch.obs)
    log_probs = ts.policy.dist_log_prob(dist, batch.actions)
    total_weight = jnp.maximum(jnp.sum(batch.weights), 1.0)
    advantages = jax.lax.stop_gradient(batch.advantages)
    policy_loss = -jnp.sum(advantages * log_probs * batch.weights) / total_weight
    entropy = jnp.sum(ts.policy.dist_entropy(dist) * batch.weights) / total_weight
    return policy_loss - core.run_config(ts).entropy_coef * entropy, {"policy_loss": policy_loss, "entropy": entropy}


def policy_step(ts: TrainState, batch: core.Batch) -> tuple[TrainState, dict[str, jax.Array]]:
    """One optimizer step on ``loss``; returns the new state and the loss diagnostics with
    ``loss`` and the pre-clipping ``grad_norm``."""
    (total, diagnostics), grads = jax.value_and_grad(loss, argnums=1, has_aux=True)(ts, ts.params, batch)
    updates, opt_state = optimizer(core.run_config(ts), ts.config).update(grads, ts.opt_state, ts.params)
    ts = ts.replace(params=optax.apply_updates(ts.params, updates), opt_state=opt_state)
    return ts, {**diagnostics, "loss": total, "grad_norm": optax.tree.norm(grads)}


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One REINFORCE iteration (module docstring); pure, jittable, vmappable over seeds."""
    old = ts
    ts, traj, _ = core.phase_sample(ts)
    batch = phase_returns(ts, traj)
    ts, diagnostics = policy_step(ts, batch)
    kl = core.mean_kl(ts, old.params, ts.params, batch)
    return core.finish_iteration(old, ts, traj, loss=diagnostics["loss"], kl=kl, metrics=diagnostics)
