"""Published settings that the presets of several tasks start from: plain read-only ``Config``
overrides, each with where it comes from. A setting that only one task's presets use lives in that
task's module instead (``jaxpg.algos.presets.<task>``)."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

# MinPy's parallel A2C: n actors in lock-step, t_max 5, RMSprop, entropy bonus. The `minpy` and
# `atari` presets of A2C, and Tianshou's A2C (below), start from it.
A2C_MINPY: Mapping[str, Any] = MappingProxyType(
    dict(
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
    )
)

# Brax's PPO on MJX Hopper (Brax's published Hopper settings): 2048 envs, unrolls of 20 steps, 32
# minibatches x 4 epochs, lr 3e-4, entropy 1e-3, gamma 0.99, reward scaling 10, observation
# normalisation, no gradient clipping; horizon 160 holds Brax's samples per update (327,680) and
# minibatch size (10,240). Hopper's, Ant's and Humanoid's PPO presets start from it. How each
# preset was chosen: docs/algorithms.md, "How the presets were chosen".
PPO_BRAX_HOPPER: Mapping[str, Any] = MappingProxyType(
    dict(
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
    )
)

# PPO at large batch on one GPU: brax_hopper's networks and losses with 8192 envs x 32 steps in 8
# minibatches of 32,768 (Hopper's hopper_gpu; the `*_fast` presets of Walker2d, HalfCheetah and
# Pusher), the mean policy evaluated every 20 iterations.
PPO_LARGE_BATCH: Mapping[str, Any] = MappingProxyType(
    {**PPO_BRAX_HOPPER, "num_envs": 8192, "horizon": 32, "num_minibatches": 8, "eval_every": 20}
)

# NPG on Hopper from the command line (Hopper's `hopper` preset), which NPG_1M varies.
NPG_HOPPER: Mapping[str, Any] = MappingProxyType(
    dict(
        num_envs=256,
        horizon=64,
        kl_delta=0.07,
        normalize_observations=True,
        log_std_init=0.0,
        value_hidden=(128, 128),
        value_epochs=10,
        value_minibatches=16,
        value_epoch_samples=16384,
        fisher_samples=16384,
        normalize_value_targets=True,
        eval_envs=16,
        eval_every=120,
    )
)

# NPG within 1 M env steps (120 iterations of 256 envs x 32 steps = 0.98 M): the `hopper` preset
# with half the horizon (twice the updates) and a wider initial policy (log-std 1: std 2.7 before
# clipping), which keeps Hopper's seeds out of the "dive forward once" optimum. The NPG `*_1m`
# presets of every MuJoCo task start from it and change its initial log-std (and step size).
NPG_1M: Mapping[str, Any] = MappingProxyType({**NPG_HOPPER, "horizon": 32, "log_std_init": 1.0})

# PPO within 1 M env steps at Tianshou's MuJoCo settings (Ant's and Humanoid's `*_1m`): 16 envs x
# 128 steps (2048 samples), 10 epochs x 32 minibatches, lr 3e-4 annealed to 0 over the 488
# iterations (0.999 M env steps), 64x64 tanh networks, initial log-std -0.5, observation
# normalisation, gradients clipped at 0.5.
PPO_SMALL_BATCH: Mapping[str, Any] = MappingProxyType(
    dict(
        num_envs=16,
        horizon=128,
        gamma=0.99,
        gae_lambda=0.95,
        normalize_observations=True,
        policy_hidden=(64, 64),
        value_hidden=(64, 64),
        policy_activation="tanh",
        value_activation="tanh",
        log_std_init=-0.5,
        num_epochs=10,
        num_minibatches=32,
        lr=3e-4,
        anneal_lr_iterations=488,
        max_grad_norm=0.5,
        entropy_coef=0.0,
        reward_scaling=1.0,
        eval_envs=16,
        eval_every=122,
    )
)

# Ant's and Humanoid's task option for their 1 M-step presets: the contact forces left out of the
# observation, as Ant-v3 did (MuJoCo 2 left those numbers zero; Gymnasium's replay gets the same
# keyword).
NO_CONTACT_FORCES: Mapping[str, Any] = MappingProxyType({"include_cfrc_ext_in_observation": False})

# Tianshou's initialisation for its MuJoCo actor-critics: orthogonal kernels, zero biases, and the
# policy's last layer scaled by 0.01 (initial mean actions near 0).
TIANSHOU_INIT: Mapping[str, Any] = MappingProxyType(dict(network_init="orthogonal", policy_head_scale=0.01))

# The networks and normalisations Tianshou's MuJoCo scripts share (A2C, NPG, TRPO, PPO): its
# initialisation, 64x64 tanh policy and value networks, initial log-std -0.5, observation
# normalisation, normalised value targets (Tianshou scales returns by their running std; here
# they are standardised).
TIANSHOU_NETWORKS: Mapping[str, Any] = MappingProxyType(
    {
        **TIANSHOU_INIT,
        "policy_hidden": (64, 64),
        "value_hidden": (64, 64),
        "policy_activation": "tanh",
        "value_activation": "tanh",
        "log_std_init": -0.5,
        "normalize_observations": True,
        "normalize_value_targets": True,
    }
)

# Tianshou's MuJoCo A2C (1 M env steps in 12,500 iterations; Ant's and Humanoid's `*_1m`): MinPy's
# (16 envs x 5 steps, RMSprop 7e-4, entropy bonus 0.01, value weight 0.5, gradients clipped at 0.5)
# with PyTorch's epsilon 1e-5 added to the root, the learning rate decaying linearly to 0 over
# Tianshou's 3 M-step runs (37,500 iterations: two thirds remain at 1 M; Ant's preset decays it to 0
# at 1 M), GAE lambda 0.95, Tianshou's networks, advantages as they are.
A2C_1M_ITERATIONS = 12500  # 1 M env steps at A2C_TIANSHOU's 16 envs x 5 steps
A2C_TIANSHOU: Mapping[str, Any] = MappingProxyType(
    {
        **A2C_MINPY,
        **TIANSHOU_NETWORKS,
        "rmsprop_eps_in_sqrt": False,
        "anneal_lr_iterations": 37500,
        "gae_lambda": 0.95,
        "normalize_advantages": False,
        "eval_envs": 16,
        "eval_every": 2500,
    }
)

# Tianshou's MuJoCo TRPO within 1 M env steps (976 iterations; Walker2d's `walker2d_1m`): 16 envs x
# 64 steps (1024 samples an update), max KL 0.01, a line search of 10 steps shrinking by 0.8, 10
# conjugate-gradient iterations with damping 0.1, advantages normalised, GAE(0.99, 0.95),
# Tianshou's networks, the value network fitted by 20 full-batch Adam steps at 1e-3 an update.
TRPO_TIANSHOU: Mapping[str, Any] = MappingProxyType(
    {
        **TIANSHOU_NETWORKS,
        "num_envs": 16,
        "horizon": 64,
        "max_kl": 0.01,
        "backtracks": 10,
        "backtrack_ratio": 0.8,
        "cg_iters": 10,
        "cg_damping": 0.1,
        "gamma": 0.99,
        "gae_lambda": 0.95,
        "normalize_advantages": True,
        "value_lr": 1e-3,
        "value_epochs": 20,
        "value_batch_size": 0,
        "eval_envs": 8,
        "eval_every": 245,
    }
)

# TRPO within 1 M env steps at SB3 RL Zoo's tuned MuJoCo settings (488 iterations; Swimmer's and
# Reacher's presets): Tianshou's TRPO but for 2 envs x 1024 steps (2048 samples an update), 25
# conjugate-gradient iterations, the value network fitted by 20 epochs of minibatches of 128 (not
# 20 full-batch steps) and initial log-std 0. SB3's orthogonal initialisation is Tianshou's; the
# Zoo normalises rewards, here the value targets are standardised.
TRPO_ZOO_MUJOCO: Mapping[str, Any] = MappingProxyType(
    {
        **TRPO_TIANSHOU,
        "num_envs": 2,
        "horizon": 1024,
        "cg_iters": 25,
        "value_batch_size": 128,
        "log_std_init": 0.0,
        "eval_every": 61,
    }
)
