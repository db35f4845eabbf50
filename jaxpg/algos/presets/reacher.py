"""Reacher's presets: within 1 M env steps (NPG; TRPO at SB3 RL Zoo's settings) and TRPO's fast
preset. Scores: BENCHMARKS.md, "The suite within 1 M env steps" and "The suite on one GPU, fast"."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from jaxpg.algos.presets.recipes import NPG_1M, TRPO_ZOO_MUJOCO
from jaxpg.algos.presets.row import Preset, Rows

# The Zoo's TRPO for Reacher at log-std -0.5 (its control cost punishes wide actions). Both TRPO
# presets start from it.
TRPO_ZOO_REACHER: Mapping[str, Any] = MappingProxyType({**TRPO_ZOO_MUJOCO, "log_std_init": -0.5})

ROWS: Rows = {
    # NPG within 1 M env steps, the best of the settings screened over 4 seeds on a CPU: log-std
    # -0.5 and 480 updates of 64 envs; TRPO's preset scores higher.
    ("npg", "reacher_1m"): Preset(
        tasks=("reacher",), overrides={**NPG_1M, "num_envs": 64, "log_std_init": -0.5}, iterations=480
    ),
    ("trpo", "reacher_1m"): Preset(tasks=("reacher",), overrides=TRPO_ZOO_REACHER, iterations=488),
    # The fast preset: `reacher_1m` with 16 times the samples an update (512 envs x 64 steps, 15.99 M
    # env steps in 488 updates), the value network fitted in minibatches of 1024 (640 steps an
    # update), the mean policy evaluated every 50 iterations; it scored above PPO's large batch.
    ("trpo", "reacher_fast"): Preset(
        tasks=("reacher",),
        overrides={**TRPO_ZOO_REACHER, "num_envs": 512, "horizon": 64, "value_batch_size": 1024, "eval_every": 50},
        iterations=488,
    ),
}
