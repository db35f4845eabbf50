"""Advantage Actor-Critic, the synchronous form of A3C (Mnih et al. 2016), as in MinPy's example.

``num_envs`` actors step in lock-step with one batched forward pass of the policy. One iteration:
  1. continue every actor for ``horizon`` steps (the paper's ``t_max``) from where the last
     iteration left it, resetting finished episodes on the fly;
  2. advantages by GAE(gamma, lambda) bootstrapped through the value of the last observation
     (``gae_lambda=1`` gives the paper's n-step returns ``sum_k gamma^k r_{t+k} +
     gamma^(t_max - t) V(s_{t_max}) - V(s_t)``);
  3. one gradient step on ``-E[A log pi(a|s)] + value_coef * E[(V(s) - R)^2]
     - entropy_coef * E[H(pi(.|s))]`` with RMSprop (the paper's choice) or Adam, after clipping
     the global gradient norm: the joint actor-critic loss without clipping, policy and value
     sharing the optimizer (``actor_critic.gradient_step``, shared with PPO);
  4. reject non-finite updates, update observation statistics (``core.finish_iteration``).

It works with every policy ``core.make_networks`` builds: categorical on a discrete task
(``cartpole``), Gaussian on a continuous one (``inverted_pendulum``).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import jax
import optax

from jaxpg.algos import actor_critic, core, presets
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env


@dataclasses.dataclass(frozen=True)
class Config(actor_critic.ActorCriticConfig):
    """A2C hyperparameters (defaults: a quick CPU setting on ``cartpole`` that reaches 500 but does
    not stay there; the ``cartpole`` preset, with scaled rewards, is the tested one that does).

    ``horizon`` is ``t_max``; ``optimizer`` is ``"rmsprop"`` (decay ``rmsprop_decay``, epsilon
    ``eps``, added inside the square root with ``rmsprop_eps_in_sqrt`` as optax and MXNet do, or
    to the root as PyTorch does; the paper's shared-statistics RMSprop becomes ordinary RMSprop in
    the synchronous setting) or ``"adam"`` (epsilon ``eps``); the learning rate ``lr`` decays
    linearly to 0 over ``anneal_lr_iterations`` iterations when that is > 0 (one optimizer step
    each); ``max_grad_norm`` 0 turns clipping off. The remaining fields are those of
    ``actor_critic.ActorCriticConfig``.
    """

    FIELD_CHOICES: ClassVar[dict[str, tuple[str, ...]]] = {"optimizer": ("rmsprop", "adam")}

    num_envs: int = 64
    horizon: int = 16
    optimizer: str = "adam"
    lr: float = 3e-3
    rmsprop_decay: float = 0.99
    rmsprop_eps_in_sqrt: bool = True
    eps: float = 1e-5
    max_grad_norm: float = 0.5
    value_coef: float = 0.5
    entropy_coef: float = 0.01
    gae_lambda: float = 1.0
    normalize_advantages: bool = False

    # rmsprop_decay stays static: optax computes 1 - decay in Python, which a traced value would round apart.
    TRACED_FIELDS: ClassVar[tuple[str, ...]] = ("lr", "eps")

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.optimizer not in ("rmsprop", "adam"):
            raise ValueError(f"optimizer must be 'rmsprop' or 'adam', got {self.optimizer!r}")
        if not self.lr > 0:
            raise ValueError(f"lr must be > 0, got {self.lr}")
        if not 0 <= self.rmsprop_decay < 1:
            raise ValueError(f"rmsprop_decay must be in [0, 1), got {self.rmsprop_decay}")


# Named Config overrides: a read-only view of this algorithm's rows of ``presets.TABLE``.
PRESETS = presets.by_algorithm("a2c")


def optimizer(config: Config, structure: Config | None = None) -> optax.GradientTransformation:
    """Gradient clipping, then RMSprop or Adam at ``lr``, annealed over one optimizer step an
    iteration (``actor_critic.learning_rate_schedule``). ``config``'s numbers may be traced
    (``core.run_config``); ``structure`` (default ``config``) then says whether to clip."""
    structure = config if structure is None else structure
    lr = actor_critic.learning_rate_schedule(config.lr, config, 1)
    if config.optimizer == "rmsprop":
        step = optax.rmsprop(lr, decay=config.rmsprop_decay, eps=config.eps, eps_in_sqrt=config.rmsprop_eps_in_sqrt)
    else:
        step = optax.adam(lr, eps=config.eps)
    clip = optax.clip_by_global_norm(config.max_grad_norm) if structure.max_grad_norm > 0 else optax.identity()
    return optax.chain(clip, step)


def init(key: jax.Array, env: Env, config: Config) -> TrainState:
    """A fresh ``TrainState``: networks, the joint optimizer state, env batch."""
    return actor_critic.init_state(key, env, config, optimizer(config))


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One A2C iteration (module docstring); pure, jittable, vmappable over seeds."""
    old = ts
    ts, traj, _ = core.phase_sample(ts)
    ts, learning_traj = actor_critic.phase_rewards(ts, traj)
    batch = actor_critic.phase_advantages(ts, learning_traj)
    ts, fit_batch = core.standardise_value_targets(ts, batch)
    joint, opt_state, diagnostics = actor_critic.gradient_step(
        ts, optimizer(core.run_config(ts), ts.config), actor_critic.joint_params(ts), ts.opt_state, fit_batch
    )
    ts = actor_critic.with_joint_params(ts, joint, opt_state)
    metrics = {name: diagnostics[name] for name in ("entropy", "policy_loss", "value_loss", "grad_norm", "loss")}
    kl = core.mean_kl(ts, old.params, ts.params, batch)
    return core.finish_iteration(old, ts, traj, loss=diagnostics["loss"], kl=kl, metrics=metrics)
