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
from typing import Any, ClassVar

import jax
import optax

from jaxpg.algos import actor_critic, core
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env


@dataclasses.dataclass(frozen=True)
class Config(actor_critic.ActorCriticConfig):
    """A2C hyperparameters (defaults: a quick CPU setting on ``cartpole`` that reaches 500 but does
    not stay there; the ``cartpole`` preset, with scaled rewards, is the tested one that does).

    ``horizon`` is ``t_max``; ``optimizer`` is ``"rmsprop"`` (decay ``rmsprop_decay``, epsilon
    ``eps``; the paper's shared-statistics RMSprop becomes ordinary RMSprop in the synchronous
    setting) or ``"adam"`` (epsilon ``eps``); ``max_grad_norm`` 0 turns clipping off. The
    remaining fields are those of ``actor_critic.ActorCriticConfig``.
    """

    FIELD_CHOICES: ClassVar[dict[str, tuple[str, ...]]] = {"optimizer": ("rmsprop", "adam")}

    num_envs: int = 64
    horizon: int = 16
    optimizer: str = "adam"
    lr: float = 3e-3
    rmsprop_decay: float = 0.99
    eps: float = 1e-5
    max_grad_norm: float = 0.5
    value_coef: float = 0.5
    entropy_coef: float = 0.01
    gae_lambda: float = 1.0
    normalize_advantages: bool = False

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.optimizer not in ("rmsprop", "adam"):
            raise ValueError(f"optimizer must be 'rmsprop' or 'adam', got {self.optimizer!r}")
        if not self.lr > 0:
            raise ValueError(f"lr must be > 0, got {self.lr}")
        if not 0 <= self.rmsprop_decay < 1:
            raise ValueError(f"rmsprop_decay must be in [0, 1), got {self.rmsprop_decay}")


PRESETS: dict[str, dict[str, Any]] = {
    # Pong from 80x80 difference frames (jaxpg's pong and ALE's atari_pong): the seed's network,
    # 6400 -> 200 (ReLU), and a value network like it; t_max 8, Adam, GAE lambda 0.95, entropy
    # bonus 0.01. lr 1e-3 suits small batches (32 envs on a CPU; 2e-3 did worse there); with 1024
    # or more envs on a GPU, 2e-3 reached a running reward of 10 sooner (BENCHMARKS.md, section J).
    "pong": dict(
        policy_hidden=(200,),
        policy_activation="relu",
        value_hidden=(200,),
        value_activation="relu",
        horizon=8,
        optimizer="adam",
        lr=1e-3,
        gamma=0.99,
        gae_lambda=0.95,
        entropy_coef=0.01,
        value_coef=0.5,
        max_grad_norm=0.5,
        eval_envs=0,
    ),
    # MinPy's parallel A2C: n actors in lock-step, t_max 5, RMSprop, entropy bonus.
    "minpy": dict(
        num_envs=16,
        horizon=5,
        optimizer="rmsprop",
        lr=7e-4,
        rmsprop_decay=0.99,
        eps=1e-5,
        gamma=0.99,
        gae_lambda=1.0,
        entropy_coef=0.01,
        value_coef=0.5,
        max_grad_norm=0.5,
    ),
    # Solves cartpole on two CPU cores and stays solved (tests/test_learning.py: the mean policy of
    # seeds 0-3 returned 500 at every evaluation from iteration 400 to 2000). Rewards are scaled
    # by 0.1: cartpole's returns reach ~100 at gamma 0.99, so unscaled the value loss dominates
    # the joint gradient clipped to norm 0.5 and the policy's share of each step is noise; with
    # the former lr 3e-3 and no scaling the seeds touched 500 within 60-300 iterations but kept
    # collapsing (means of the last 3 evaluations at the end: 329 and 470 after 600 iterations;
    # at lr 1e-3 363-500 after 1000, at 3e-4 below 500 for all four seeds after 2500).
    "cartpole": dict(
        num_envs=64,
        horizon=16,
        optimizer="adam",
        lr=1e-3,
        reward_scaling=0.1,
        gamma=0.99,
        gae_lambda=1.0,
        entropy_coef=0.01,
        value_coef=0.5,
        max_grad_norm=0.5,
    ),
}

# Atari games from pixels (atari_pong) with the Nature network (three convolutions, 512 ReLU units)
# before the policy and the value function: the A2C of Mnih et al. (2016) as the Stable-Baselines3
# zoo runs it on Atari, MinPy's settings (16 envs, t_max 5, RMSprop 7e-4, decay 0.99, eps 1e-5,
# entropy 0.01, gradient norm 0.5, n-step returns) with the value loss weighted 0.25.
PRESETS["atari"] = {**PRESETS["minpy"], "value_coef": 0.25, **actor_critic.ATARI_NETWORKS}


def optimizer(config: Config) -> optax.GradientTransformation:
    """Gradient clipping, then RMSprop or Adam at ``lr``."""
    if config.optimizer == "rmsprop":
        step = optax.rmsprop(config.lr, decay=config.rmsprop_decay, eps=config.eps)
    else:
        step = optax.adam(config.lr, eps=config.eps)
    return optax.chain(core.clip_gradients(config.max_grad_norm), step)


def init(key: jax.Array, env: Env, config: Config) -> TrainState:
    """A fresh ``TrainState``: networks, the joint optimizer state, env batch."""
    return actor_critic.init_state(key, env, config, optimizer(config))


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One A2C iteration (module docstring); pure, jittable, vmappable over seeds."""
    old = ts
    ts, traj, _ = core.phase_sample(ts)
    batch = actor_critic.phase_advantages(ts, traj)
    joint, opt_state, diagnostics = actor_critic.gradient_step(
        ts, optimizer(ts.config), actor_critic.joint_params(ts), ts.opt_state, batch
    )
    ts = actor_critic.with_joint_params(ts, joint, opt_state)
    metrics = {name: diagnostics[name] for name in ("entropy", "policy_loss", "value_loss", "grad_norm", "loss")}
    kl = core.mean_kl(ts, old.params, ts.params, batch)
    return core.finish_iteration(old, ts, traj, loss=diagnostics["loss"], kl=kl, metrics=metrics)


# The tasks each preset was made for (``jaxpg.algos.preset`` refuses it on others); unnamed: any task.
PRESET_TASKS: dict[str, tuple[str, ...]] = {
    "pong": ("pong", "atari_pong"),
    "atari": ("atari_pong", "pong"),
    "cartpole": ("cartpole",),
}
