"""Hopper's presets: NPG from the command line and within 1 M env steps, and the large-batch
presets of NPG and PPO on one GPU. Scores and times: BENCHMARKS.md, "The card command", "The suite
on one GPU, fast" and "Time to a score"."""

from __future__ import annotations

from jaxpg.algos.presets.recipes import NPG_1M, NPG_HOPPER, PPO_BRAX_HOPPER, PPO_LARGE_BATCH
from jaxpg.algos.presets.row import Preset, Rows

ROWS: Rows = {
    # Hopper from the command line (experiments/hopper.py's default before hopper_1m): 256 envs x 64
    # steps, 120 iterations (1.97 M env steps), chosen over eight seeds on one GPU; the value
    # fit and the Fisher-vector products capped at 16384 samples so that they stay cheap at
    # large --num-envs.
    ("npg", "hopper"): Preset(tasks=("hopper",), overrides=NPG_HOPPER),
    # Hopper within 1 M env steps (the command line's default): NPG_1M with the policy's noise held
    # at log-std 1 (a floor and a ceiling there), and the mean policy evaluated with its clipped
    # mean E[clip(a)], the mean of the actions the training env executed (clip(mean) is far from it
    # at std 2.7 in [-1, 1]); more seeds past 3000 in Gymnasium than with clip(mean)
    # (docs/benchmarks_archive.md, section AV).
    ("npg", "hopper_1m"): Preset(
        tasks=("hopper",),
        overrides={
            **NPG_1M,
            "log_std_min": 1.0,
            "log_std_final": 1.0,
            "anneal_log_std_iterations": 120,
            "eval_action": "clipped_mean",
        },
        iterations=120,
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
    # Brax's published PPO settings for Hopper.
    ("ppo", "brax_hopper"): Preset(tasks=("hopper",), overrides=PPO_BRAX_HOPPER),
    # The same with unrolls of 20 steps per update (more, smaller updates).
    ("ppo", "brax_hopper_short"): Preset(
        tasks=("hopper",),
        overrides={**PPO_BRAX_HOPPER, "horizon": 20, "eval_every": 50},
    ),
    # Hopper on one GPU: PPO_LARGE_BATCH, the mean policy evaluated every 50 iterations on 32
    # envs, as NPG's hopper_gpu.
    ("ppo", "hopper_gpu"): Preset(tasks=("hopper",), overrides={**PPO_LARGE_BATCH, "eval_envs": 32, "eval_every": 50}),
}
