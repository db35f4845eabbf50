"""Pong's presets, for jaxpg's ``pong`` and ALE's ``atari_pong`` alike: MinPy's A2C from 80x80
difference frames, and the Atari literature's A2C and PPO with the Nature network. Scores:
BENCHMARKS.md, "Pong"."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from jaxpg.algos.presets.recipes import A2C_MINPY
from jaxpg.algos.presets.row import Preset, Rows

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

ROWS: Rows = {
    # Pong from 80x80 difference frames: the seed's network, 6400 -> 200 (ReLU), and a value
    # network like it; t_max 8, Adam, GAE lambda 0.95, entropy bonus 0.01, lr 1e-3 for small
    # batches.
    ("a2c", "pong"): Preset(
        tasks=("pong", "atari_pong"),
        overrides=dict(
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
    ),
    # Atari games from pixels with the Nature network before the policy and the value function:
    # the A2C of Mnih et al. (2016) as the Stable-Baselines3 zoo runs it on Atari, MinPy's settings
    # (16 envs, t_max 5, RMSprop 7e-4, decay 0.99, eps 1e-5, entropy 0.01, gradient norm 0.5,
    # n-step returns) with the value loss weighted 0.25.
    ("a2c", "atari"): Preset(
        tasks=("atari_pong", "pong"),
        overrides={**A2C_MINPY, "value_coef": 0.25, **ATARI_NETWORKS},
    ),
    # Atari games from pixels: the PPO of the Atari literature (Schulman et al. 2017's Atari
    # settings as CleanRL's ppo_atari keeps them: horizon 128, 4 epochs of 4 minibatches, Adam
    # 2.5e-4 annealed to 0, clip 0.1, entropy 0.01, value loss 0.5 with value clipping, gradient
    # norm 0.5, GAE(0.99, 0.95), orthogonal initialisation) with the Nature network in front of
    # each of the policy and the value function; 16 games, the learning rate annealed over 2500
    # iterations (5.1 M agent steps, 20 M frames).
    ("ppo", "atari"): Preset(
        tasks=("atari_pong", "pong"),
        overrides=dict(
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
            **ATARI_NETWORKS,
        ),
    ),
}
