"""Every algorithm's presets in one table: named ``Config`` overrides keyed by
``(algorithm, preset name)``, each with the tasks it was made for (or ``None``: any task).

``jaxpg.algos.preset(algo, name, task)`` and ``jaxpg.algos.preset_names(algo, task)`` read the
table; each algorithm module's ``PRESETS`` is ``by_algorithm(algo)``, a read-only view of its
rows (``npg.PRESETS["hopper"]``). The settings several rows share are in
``jaxpg.algos.preset_settings``. This module holds plain data and imports no algorithm, so any
module may import it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from jaxpg.algos.preset_settings import (
    A2C_1M_ITERATIONS,
    A2C_MINPY,
    A2C_TIANSHOU,
    ANT_1M_A2C_ENV,
    ATARI_NETWORKS,
    HUMANOID_1M_ENV,
    LYCEUM_SETTINGS,
    NO_CONTACT_FORCES,
    NPG_1M,
    NPG_HOPPER,
    NPG_HOPPER_1M,
    PPO_BRAX_HOPPER,
    PPO_LARGE_BATCH,
    PPO_SMALL_BATCH,
    PPO_ZOO_HALF_CHEETAH,
    TIANSHOU_INIT,
    TRPO_REACHER_FAST,
    TRPO_TIANSHOU,
    TRPO_ZOO_REACHER,
    TRPO_ZOO_SWIMMER,
)


@dataclasses.dataclass(frozen=True)
class Preset:
    """One row of the table: ``overrides`` (``Config`` field -> value), the ``tasks`` they were
    made for (``None``: any task), the ``iterations`` a run of the preset takes by default on
    the command line (``None``: the command's own default) and the task options it sets
    (``env_kwargs``, keyword arguments of ``jaxpg.envs.make`` with Gymnasium's meaning, which the
    Gymnasium replay passes on too; besides them the policy's ``action_scaling`` and the physics
    ``fidelity`` it was chosen in, which the command line's flags override)."""

    overrides: Mapping[str, Any]
    tasks: tuple[str, ...] | None = None
    iterations: int | None = None
    env_kwargs: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "overrides", MappingProxyType(dict(self.overrides)))
        object.__setattr__(self, "env_kwargs", MappingProxyType(dict(self.env_kwargs)))

    def suits(self, task: str) -> bool:
        """Whether the preset was made for ``task`` (every task, when it names none)."""
        return self.tasks is None or task in self.tasks


TABLE: Mapping[tuple[str, str], Preset] = MappingProxyType(
    {
        # --- NPG ---
        # inverted_pendulum on a 2-core CPU: 4096 samples an iteration, a small KL bound that keeps
        # the solved policy solved.
        ("npg", "pendulum_cpu"): Preset(
            tasks=("inverted_pendulum",),
            overrides=dict(
                num_envs=32,
                horizon=128,
                gamma=0.99,
                kl_delta=0.03,
                policy_hidden=(32, 32),
                value_hidden=(64, 64),
                value_batch_size=512,
            ),
        ),
        # Hopper from the command line (experiments/hopper.py's default before hopper_1m): 256 envs x 64
        # steps, 120 iterations (1.97 M env steps), chosen over eight seeds on one GPU; the value
        # fit and the Fisher-vector products capped at 16384 samples so that they stay cheap at
        # large --num-envs.
        ("npg", "hopper"): Preset(tasks=("hopper",), overrides=NPG_HOPPER),
        # Hopper within 1 M env steps (the command line's default): NPG_1M with the noise held at
        # log-std 1 and the mean policy played as its clipped mean (BENCHMARKS.md).
        ("npg", "hopper_1m"): Preset(tasks=("hopper",), overrides=NPG_HOPPER_1M, iterations=120),
        # Walker2d and HalfCheetah within 1 M env steps, each the best of 8-10 settings over 16 seeds;
        # HalfCheetah, which does not terminate, gains from a narrow policy (std 0.6) early.
        ("npg", "walker2d_1m"): Preset(tasks=("walker2d",), overrides={**NPG_1M, "log_std_init": 0.75}, iterations=120),
        ("npg", "half_cheetah_1m"): Preset(
            tasks=("half_cheetah",), overrides={**NPG_1M, "log_std_init": -0.5, "kl_delta": 0.15}, iterations=120
        ),
        # Swimmer and Reacher within 1 M env steps, each the best of 4-7 settings over 4 seeds on a
        # CPU: Swimmer with gamma 0.9999 (its reward pays off over the whole episode); Reacher with
        # log-std -0.5 and 480 updates of 64 envs. Gymnasium medians of 8: 117, -5.14 (TRPO's: higher).
        ("npg", "swimmer_1m"): Preset(
            tasks=("swimmer",), overrides={**NPG_1M, "gamma": 0.9999, "log_std_init": 0.0}, iterations=120
        ),
        ("npg", "reacher_1m"): Preset(
            tasks=("reacher",), overrides={**NPG_1M, "num_envs": 64, "log_std_init": -0.5}, iterations=480
        ),
        # Pusher within 1 M env steps: Reacher's 480 updates of 64 envs at log-std 0, one setting
        # screened (4 seeds on a CPU, Gymnasium median -38.3); untuned beyond that.
        ("npg", "pusher_1m"): Preset(
            tasks=("pusher",), overrides={**NPG_1M, "num_envs": 64, "log_std_init": 0.0}, iterations=480
        ),
        # Hopper on one GPU, large batches, the mean policy evaluated every 50 iterations.
        ("npg", "hopper_gpu"): Preset(
            tasks=("hopper",),
            overrides=dict(
                num_envs=8192,
                horizon=64,
                normalize_observations=True,
                value_batch_size=32768,
                value_epochs=2,
                kl_delta=0.1,
                policy_hidden=(64, 64),
                value_hidden=(256, 256),
                eval_envs=32,
                eval_every=50,
            ),
        ),
        # LyceumAI's NaturalPolicyGradient on HopperV2 (Summers et al., L4DC 2020).
        ("npg", "lyceum"): Preset(overrides=dict(**LYCEUM_SETTINGS, kl_delta=0.05)),
        # --- TRPO ---
        ("trpo", "lyceum"): Preset(overrides=dict(**LYCEUM_SETTINGS, max_kl=0.05)),
        # Within 1 M env steps: Walker2d at Tianshou's TRPO settings (Gymnasium median 4018 of 16
        # seeds), Swimmer and Reacher at SB3 RL Zoo's (preset_settings).
        ("trpo", "walker2d_1m"): Preset(tasks=("walker2d",), overrides=TRPO_TIANSHOU, iterations=976),
        ("trpo", "swimmer_1m"): Preset(tasks=("swimmer",), overrides=TRPO_ZOO_SWIMMER, iterations=488),
        ("trpo", "reacher_1m"): Preset(tasks=("reacher",), overrides=TRPO_ZOO_REACHER, iterations=488),
        # Swimmer's fast preset: `swimmer_1m` from 16 envs x 128 steps (the same 2048 samples an
        # update, 1/8 of the steps in a row); on one H200 all 8 seeds found the fast gait.
        ("trpo", "swimmer_fast"): Preset(
            tasks=("swimmer",),
            overrides={**TRPO_ZOO_SWIMMER, "num_envs": 16, "horizon": 128, "eval_every": 50},
            iterations=488,
        ),
        # Reacher's fast preset: `reacher_1m` with 16 times the samples an update (preset_settings).
        ("trpo", "reacher_fast"): Preset(tasks=("reacher",), overrides=TRPO_REACHER_FAST, iterations=488),
        # --- REINFORCE ---
        # On inverted_pendulum: the Gymnasium REINFORCE tutorial. Shared tanh trunk 16 -> 32,
        # linear mean and softplus-std heads, AdamW lr 1e-4, gamma 0.99, one update per episode,
        # raw (unnormalised) returns, PyTorch's default initialisation.
        ("reinforce", "gymnasium_tutorial"): Preset(
            tasks=("inverted_pendulum",),
            overrides=dict(
                sampling="episodic",
                num_envs=1,
                horizon=1000,
                gamma=0.99,
                policy="state_std_gaussian",
                policy_hidden=(16, 32),
                policy_activation="tanh",
                network_init="pytorch",
                optimizer="adamw",
                lr=1e-4,
                weight_decay=0.01,
                return_normalization="none",
            ),
        ),
        # Seed 5, on cartpole: Kokoyi's policy gradient. Categorical policy 4 -> 128 (ReLU) -> 2,
        # Adam lr 0.01, gamma 0.99, returns normalised per episode, one update per episode.
        ("reinforce", "kokoyi"): Preset(
            tasks=("cartpole",),
            overrides=dict(
                sampling="episodic",
                num_envs=1,
                horizon=500,
                gamma=0.99,
                policy_hidden=(128,),
                policy_activation="relu",
                network_init="pytorch",
                optimizer="adam",
                lr=1e-2,
                return_normalization="episode",
            ),
        ),
        # --- VPG ---
        # On inverted_pendulum: the PyTorch Lightning VPG. Policy 64 -> 64 tanh with a global
        # log-std, baseline of the same shape, Adam lr 3.9e-3, discount 0.9, 2500 samples per
        # epoch (here 10 envs x 250 steps of continuing sampling, the data set carried across
        # episode ends), advantages = normalised returns - baseline, baseline fitted to the
        # normalised returns with one full-batch step per epoch; 100 epochs in the seed.
        ("vpg", "lightning"): Preset(
            tasks=("inverted_pendulum",),
            overrides=dict(
                sampling="continuing",
                num_envs=10,
                horizon=250,
                gamma=0.9,
                policy="gaussian",
                policy_hidden=(64, 64),
                policy_activation="tanh",
                network_init="pytorch",
                log_std_init=0.0,
                value_hidden=(64, 64),
                value_activation="tanh",
                optimizer="adam",
                lr=3.9e-3,
                value_lr=3.9e-3,
                value_epochs=1,
                value_batch_size=0,
                return_normalization="batch",
            ),
        ),
        # --- A2C ---
        # Pong from 80x80 difference frames (jaxpg's pong and ALE's atari_pong): the seed's
        # network, 6400 -> 200 (ReLU), and a value network like it; t_max 8, Adam, GAE lambda
        # 0.95, entropy bonus 0.01, lr 1e-3 for small batches.
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
        ("a2c", "minpy"): Preset(overrides=A2C_MINPY),
        # Within 1 M env steps at Tianshou's MuJoCo A2C settings (preset_settings.A2C_TIANSHOU),
        # contact forces out of the observation; Ant trained in Gymnasium's own physics
        # (ANT_1M_A2C_ENV), its learning rate decaying to 0 at 1 M (Tianshou's: at 3 M), Humanoid's
        # policy acting in [-1, 1], scaled to its [-0.4, 0.4] (HUMANOID_1M_ENV). Gymnasium v5 medians
        # at 1 M env steps: Ant 3595 (16 seeds, one H100; decaying to 3 M: 3488 over 32 on H200s,
        # 2420 in the fast physics; PPO's ant_1m 2260); Humanoid 4482 (32 seeds, 29 above
        # Tianshou's 1726; 647 at 0.91 M with its actions in Humanoid's units).
        ("a2c", "ant_1m"): Preset(
            tasks=("ant",),
            overrides={**A2C_TIANSHOU, "anneal_lr_iterations": A2C_1M_ITERATIONS},
            env_kwargs=ANT_1M_A2C_ENV,
            iterations=A2C_1M_ITERATIONS,
        ),
        ("a2c", "humanoid_1m"): Preset(
            tasks=("humanoid",), overrides=A2C_TIANSHOU, env_kwargs=HUMANOID_1M_ENV, iterations=A2C_1M_ITERATIONS
        ),
        # Solves cartpole on two CPU cores and stays solved; rewards scaled by 0.1 so that the
        # value loss does not swamp the joint, clipped gradient.
        ("a2c", "cartpole"): Preset(
            tasks=("cartpole",),
            overrides=dict(
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
        ),
        # Atari games from pixels (atari_pong) with the Nature network (three convolutions, 512
        # ReLU units) before the policy and the value function: the A2C of Mnih et al. (2016) as
        # the Stable-Baselines3 zoo runs it on Atari, MinPy's settings (16 envs, t_max 5, RMSprop
        # 7e-4, decay 0.99, eps 1e-5, entropy 0.01, gradient norm 0.5, n-step returns) with the
        # value loss weighted 0.25.
        ("a2c", "atari"): Preset(
            tasks=("atari_pong", "pong"),
            overrides={**A2C_MINPY, "value_coef": 0.25, **ATARI_NETWORKS},
        ),
        # --- PPO ---
        ("ppo", "brax_hopper"): Preset(tasks=("hopper",), overrides=PPO_BRAX_HOPPER),
        # The same with unrolls of 20 steps per update (more, smaller updates).
        ("ppo", "brax_hopper_short"): Preset(
            tasks=("hopper",),
            overrides={**PPO_BRAX_HOPPER, "horizon": 20, "eval_every": 50},
        ),
        # Solves inverted_pendulum on the CPU.
        ("ppo", "pendulum"): Preset(
            tasks=("inverted_pendulum",),
            overrides=dict(
                num_envs=32,
                horizon=32,
                num_minibatches=8,
                num_epochs=10,
                lr=1e-3,
                gamma=0.99,
                gae_lambda=0.95,
                eval_envs=8,
            ),
        ),
        # Atari games from pixels (atari_pong): the PPO of the Atari literature (Schulman et al.
        # 2017's Atari settings as CleanRL's ppo_atari keeps them: horizon 128, 4 epochs of 4
        # minibatches, Adam 2.5e-4 annealed to 0, clip 0.1, entropy 0.01, value loss 0.5 with
        # value clipping, gradient norm 0.5, GAE(0.99, 0.95), orthogonal initialisation) with the
        # Nature network (three convolutions, 512 ReLU units) in front of each of the policy and
        # the value function; 16 games, the learning rate annealed over 2500 iterations (5.1 M agent
        # steps, 20 M frames).
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
        # Hopper on one GPU: PPO_LARGE_BATCH, the mean policy evaluated every 50 iterations on 32
        # envs, as NPG's hopper_gpu.
        ("ppo", "hopper_gpu"): Preset(
            tasks=("hopper",), overrides={**PPO_LARGE_BATCH, "eval_envs": 32, "eval_every": 50}
        ),
        # The suite on one GPU, least wall clock to a target (the `*_fast` presets), each chosen
        # among 1-3 settings on one GPU per run (BENCHMARKS.md, "The suite on one GPU, fast"); the
        # iterations are where the measured runs stopped. Each evaluates its mean policy about ten
        # times a run (128 episodes each, a multiple of 10 iterations apart, so the blocks stay 10
        # long): evaluated every 20 iterations, the evaluations took 32-38 % of the training loop
        # on one H100. Evaluation never changes training (its key is folded off the training key).
        # Walker2d and HalfCheetah: PPO_LARGE_BATCH (HalfCheetah with unscaled rewards and no
        # entropy bonus; with Brax's halfcheetah settings, or gamma 0.95, it stayed near 2200).
        ("ppo", "walker2d_fast"): Preset(
            tasks=("walker2d",), overrides={**PPO_LARGE_BATCH, "eval_every": 60}, iterations=660
        ),
        ("ppo", "half_cheetah_fast"): Preset(
            tasks=("half_cheetah",),
            overrides={**PPO_LARGE_BATCH, "reward_scaling": 1.0, "entropy_coef": 0.0, "eval_every": 60},
            iterations=560,
        ),
        # Brax's published PPO settings for its own ant (32 minibatches x 4 epochs, gamma 0.97,
        # entropy 0.01) and humanoid (unrolls of 10: horizon 160; 32 minibatches x 8 epochs, gamma
        # 0.97, reward scaling 0.1). Ant gathers half of Brax's samples per update (163,840) from 16384
        # envs x 10 steps: on one H100 that is 1.3 times the env steps per second of 4096 envs x 40
        # and learned more per env step too (in-run returns at 98 M steps: 4736, 3862, 1779 against
        # 1363, 2783, 1285). It runs 1370 iterations, where three runs stopped by a 4.2-minute
        # training limit ended (271-279 s warm, whole process).
        ("ppo", "ant_fast"): Preset(
            tasks=("ant",),
            overrides={
                **PPO_BRAX_HOPPER,
                "num_envs": 16384,
                "horizon": 10,
                "gamma": 0.97,
                "entropy_coef": 1e-2,
                "eval_every": 150,
            },
            iterations=1370,
        ),
        # Within 1 M env steps at Tianshou's and SB3 RL Zoo's PPO settings (jaxpg.algos.preset_settings).
        # Ant and Humanoid leave the contact forces out of the observation, as Ant-v3 did (MuJoCo 2
        # left those numbers zero; Gymnasium's replay gets the same keyword): Ant with them, 569
        # and 438 on two seeds. Humanoid adds Tianshou's initialisation and its policy acting in
        # [-1, 1]. Gymnasium v5 medians on one GPU: Ant 2260 (16 seeds), Humanoid 910 (32 seeds;
        # 732 with the std alone in Humanoid's units, 605 with Ant's settings), HalfCheetah 5366
        # (16; NPG's half_cheetah_1m: 5012). All three miss Tianshou's best (BENCHMARKS.md).
        ("ppo", "ant_1m"): Preset(
            tasks=("ant",), overrides=PPO_SMALL_BATCH, env_kwargs=NO_CONTACT_FORCES, iterations=488
        ),
        ("ppo", "humanoid_1m"): Preset(
            tasks=("humanoid",),
            overrides={**PPO_SMALL_BATCH, **TIANSHOU_INIT},
            env_kwargs=HUMANOID_1M_ENV,
            iterations=488,
        ),
        ("ppo", "half_cheetah_1m"): Preset(tasks=("half_cheetah",), overrides=PPO_ZOO_HALF_CHEETAH, iterations=1953),
        ("ppo", "humanoid_fast"): Preset(
            tasks=("humanoid",),
            overrides={**PPO_BRAX_HOPPER, "num_epochs": 8, "gamma": 0.97, "reward_scaling": 0.1, "eval_every": 30},
            iterations=250,
        ),
        # Pusher: the large batch with no entropy bonus and Brax's gamma 0.95 (gamma 0.99 scored 2.6
        # lower), from two screen runs; the iterations stop where their in-run returns peaked (about
        # 260; no learning-rate decay, so a shorter run is their prefix). Swimmer's and Reacher's are
        # TRPO's.
        ("ppo", "pusher_fast"): Preset(
            tasks=("pusher",),
            overrides={**PPO_LARGE_BATCH, "gamma": 0.95, "entropy_coef": 0.0, "eval_every": 30},
            iterations=260,
        ),
    }
)


def by_algorithm(algo: str) -> Mapping[str, Mapping[str, Any]]:
    """Read-only ``{preset name: overrides}`` of ``algo``'s rows, in table order (an algorithm
    module's ``PRESETS``; empty for an algorithm without presets)."""
    return MappingProxyType({name: row.overrides for (a, name), row in TABLE.items() if a == algo})
