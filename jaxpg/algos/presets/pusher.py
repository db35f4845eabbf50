"""Pusher's presets: NPG within 1 M env steps and PPO's fast preset. Scores: BENCHMARKS.md, "The
suite within 1 M env steps" and "The suite on one GPU, fast"."""

from __future__ import annotations

from jaxpg.algos.presets.recipes import NPG_1M, PPO_LARGE_BATCH
from jaxpg.algos.presets.row import Preset, Rows

ROWS: Rows = {
    # Within 1 M env steps: Reacher's 480 updates of 64 envs at log-std 0, one setting screened on
    # a CPU; untuned beyond that.
    ("npg", "pusher_1m"): Preset(
        tasks=("pusher",), overrides={**NPG_1M, "num_envs": 64, "log_std_init": 0.0}, iterations=480
    ),
    # The large batch with no entropy bonus and Brax's gamma 0.95 (gamma 0.99 scored lower), from
    # two screen runs; the iterations stop where their in-run returns peaked (no learning-rate
    # decay, so a shorter run is their prefix).
    ("ppo", "pusher_fast"): Preset(
        tasks=("pusher",),
        overrides={**PPO_LARGE_BATCH, "gamma": 0.95, "entropy_coef": 0.0, "eval_every": 30},
        iterations=260,
    ),
}
