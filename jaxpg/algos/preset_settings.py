"""The named settings that several rows of the preset table (``jaxpg.algos.presets``) share:
plain read-only ``Config`` overrides, each with where it comes from."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

# LyceumAI's NaturalPolicyGradient on HopperV2 (Summers et al., L4DC 2020): its sampling, networks
# and value fit, which its NPG and TRPO presets share.
LYCEUM_SETTINGS: Mapping[str, Any] = MappingProxyType(
    dict(
        sampling="episodic",
        num_envs=11,
        horizon=1000,
        sample_budget=10240,
        gamma=0.995,
        gae_lambda=0.97,
        policy="gaussian",
        policy_hidden=(32, 32),
        policy_activation="tanh",
        network_init="glorot_uniform",
        log_std_init=0.0,
        value_hidden=(128, 128),
        value_activation="relu",
        value_lr=1e-3,
        value_epochs=3,
        value_batch_size=64,
        value_target="returns",
        normalize_observations=False,
    )
)

# The networks of the Atari presets of A2C and PPO: the Nature network (three convolutions, then
# 512 ReLU units) in front of the policy and, separately, of the value function, initialised
# orthogonally; no mean-policy evaluation in the run (a game to 21 points is thousands of steps).
ATARI_NETWORKS: Mapping[str, Any] = MappingProxyType(
    dict(
        conv_torso="nature",
        policy_hidden=(512,),
        policy_activation="relu",
        value_hidden=(512,),
        value_activation="relu",
        network_init="orthogonal",
        eval_envs=0,
    )
)

# MinPy's parallel A2C: n actors in lock-step, t_max 5, RMSprop, entropy bonus.
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

# Brax's PPO on MJX Hopper (the reference run in BENCHMARKS.md): 2048 envs, unrolls of 20 steps, 32
# minibatches x 4 epochs, lr 3e-4, entropy 1e-3, gamma 0.99, reward scaling 10, observation
# normalisation, no gradient clipping; horizon 160 holds Brax's samples per update (327,680) and
# minibatch size (10,240). How each preset was chosen: docs/algorithms.md, "How the presets were
# chosen".
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
# minibatches of 32,768 (hopper_gpu; the `*_fast` presets of Walker2d and HalfCheetah), the mean
# policy evaluated every 20 iterations.
PPO_LARGE_BATCH: Mapping[str, Any] = MappingProxyType(
    {**PPO_BRAX_HOPPER, "num_envs": 8192, "horizon": 32, "num_minibatches": 8, "eval_every": 20}
)

# NPG on Hopper from the command line (the `hopper` preset), which `hopper_1m` varies.
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

# NPG within 1 M env steps (120 iterations of 256 envs x 32 steps = 0.98 M): the
# `hopper` preset with half the horizon (twice the updates) and a wider initial policy (log-std 1:
# std 2.7 before clipping), which keeps Hopper's seeds out of the "dive forward once" optimum. The
# `*_1m` presets of the other tasks change its initial log-std (and step size).
NPG_1M: Mapping[str, Any] = MappingProxyType({**NPG_HOPPER, "horizon": 32, "log_std_init": 1.0})

# Hopper within 1 M env steps (`hopper_1m`): NPG_1M with the policy's noise held at log-std 1 (a
# floor and a ceiling there), and the mean policy evaluated with its clipped mean E[clip(a)], the
# mean of the actions the training env executed (clip(mean) is far from it at std 2.7 in [-1, 1]).
# Over seeds 3000-3191 on one GPU, 190 of 192 scored 3000 in Gymnasium, against 173 of 192 for
# NPG_1M played with clip(mean) (BENCHMARKS.md).
NPG_HOPPER_1M: Mapping[str, Any] = MappingProxyType(
    {
        **NPG_1M,
        "log_std_min": 1.0,
        "log_std_final": 1.0,
        "anneal_log_std_iterations": 120,
        "eval_action": "clipped_mean",
    }
)

# PPO within 1 M env steps at Tianshou's MuJoCo settings: 16 envs x 128 steps (2048 samples), 10
# epochs x 32 minibatches, lr 3e-4 annealed to 0 over the 488 iterations (0.999 M env steps),
# 64x64 tanh networks, initial log-std -0.5, observation normalisation, gradients clipped at 0.5.
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
# observation (Ant-v3 had them, all zero under MuJoCo 2).
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

# Tianshou's MuJoCo A2C (1 M env steps in 12,500 iterations): MinPy's (16 envs x 5 steps, RMSprop
# 7e-4, entropy bonus 0.01, value weight 0.5, gradients clipped at 0.5) with PyTorch's epsilon 1e-5
# added to the root, the learning rate decaying linearly to 0 over Tianshou's 3 M-step runs (37,500
# iterations: two thirds remain at 1 M; Ant's preset decays it to 0 at 1 M), GAE lambda 0.95,
# Tianshou's networks, advantages as they are.
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

# Tianshou's MuJoCo TRPO within 1 M env steps (976 iterations): 16 envs x 64 steps (1024 samples an
# update), max KL 0.01, a line search of 10 steps shrinking by 0.8, 10 conjugate-gradient
# iterations with damping 0.1, advantages normalised, GAE(0.99, 0.95), Tianshou's networks, the
# value network fitted by 20 full-batch Adam steps at 1e-3 an update.
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

# Ant's A2C within 1 M env steps: the contact forces out of the observation, trained in the
# "gymnasium" fidelity (Gymnasium's own physics: RK4 at 10 ms and MuJoCo's default Newton solve, in
# place of Euler and 4 solver iterations). Ant is the suite's task whose model asks for RK4 at a
# large step and touches the floor with four legs. Seeds 0-15 in one program on one GPU, each
# final policy replayed in Gymnasium: median 3551 (10 of 16 above Tianshou's 3485) against 2420 in
# the fast physics (0 of 16; p = 0.0003), at about 3.7 times the training time; over 32 seeds in
# two programs 3488, 16 of 32 above 3485 (BENCHMARKS.md).
ANT_1M_A2C_ENV: Mapping[str, Any] = MappingProxyType({**NO_CONTACT_FORCES, "fidelity": "gymnasium"})

# Humanoid's task options for its 1 M-step presets: the contact forces out of the observation, and
# the policy acting in [-1, 1], mapped onto Humanoid's [-0.4, 0.4] (``action_scaling``), as
# Tianshou's policies act: its initial log-std -0.5 and the size of its updates then mean the
# same fraction of the range as on a task in [-1, 1]. Over 32 seeds on one GPU, PPO's Gymnasium
# median rose from 732 (16 seeds, the std alone scaled to Humanoid's units) to 910 (BENCHMARKS.md).
HUMANOID_1M_ENV: Mapping[str, Any] = MappingProxyType({**NO_CONTACT_FORCES, "action_scaling": True})

# PPO within 1 M env steps at SB3 RL Zoo's tuned HalfCheetah settings (its 1 env x 512 steps as 16
# envs x 32; 20 epochs x 8 minibatches, lr 2.06e-5, clip 0.1, gamma 0.98, lambda 0.92, initial
# log-std -2, 256x256 ReLU networks), 1953 iterations (0.9999 M env steps), rewards x 0.05, and
# PyTorch's default initialisation (the Zoo's ortho_init=False): over 16 seeds on one GPU every
# seed scored 4878-7868 in Gymnasium (median 5623), where glorot_uniform left 3 of 16 under 2300
# (median 5366); 4 CPU seeds agreed. Seeds 16-31 scored 3273-7006 (median 5145): 5514 over 32
# (BENCHMARKS.md). Advantages are standardised over the batch of 512; the Zoo's per-minibatch
# standardisation (normalize_minibatch_advantages) scored 5746 over 32 seeds, within chance.
PPO_ZOO_HALF_CHEETAH: Mapping[str, Any] = MappingProxyType(
    dict(
        num_envs=16,
        horizon=32,
        num_minibatches=8,
        num_epochs=20,
        lr=2.0633e-05,
        clip_eps=0.1,
        gae_lambda=0.92,
        gamma=0.98,
        max_grad_norm=0.8,
        value_coef=0.58096,
        entropy_coef=0.000401762,
        log_std_init=-2.0,
        policy_hidden=(256, 256),
        value_hidden=(256, 256),
        policy_activation="relu",
        value_activation="relu",
        normalize_observations=True,
        reward_scaling=0.05,
        network_init="pytorch",
        eval_envs=16,
        eval_every=500,
    )
)

# TRPO within 1 M env steps at SB3 RL Zoo's tuned MuJoCo settings (488 iterations): Tianshou's TRPO
# but for 2 envs x 1024 steps (2048 samples an update), 25 conjugate-gradient iterations, the value
# network fitted by 20 epochs of minibatches of 128 (not 20 full-batch steps) and initial log-std 0.
# SB3's orthogonal initialisation is Tianshou's; the Zoo normalises rewards, here the value targets
# are standardised.
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

# Swimmer: the Zoo's gamma 0.9999, and initial log-std 0.5 instead of the Zoo's 0, which left 2 of
# 4 seeds in the slow gait. Reacher: log-std -0.5 (its control cost punishes wide actions).
TRPO_ZOO_SWIMMER: Mapping[str, Any] = MappingProxyType({**TRPO_ZOO_MUJOCO, "gamma": 0.9999, "log_std_init": 0.5})
TRPO_ZOO_REACHER: Mapping[str, Any] = MappingProxyType({**TRPO_ZOO_MUJOCO, "log_std_init": -0.5})

# Reacher's fast preset: `reacher_1m` with 16 times the samples an update (512 envs x 64 steps, 15.99 M
# env steps in 488 updates), the value network fitted in minibatches of 1024 (640 steps an update), the
# mean policy evaluated every 50 iterations. One H100, one seed a process, evaluated every 61: Gymnasium
# median -3.48 in 59 s warm (PPO's large batch, the earlier fast preset: -3.64 in 67 s).
TRPO_REACHER_FAST: Mapping[str, Any] = MappingProxyType(
    {**TRPO_ZOO_REACHER, "num_envs": 512, "horizon": 64, "value_batch_size": 1024, "eval_every": 50}
)
