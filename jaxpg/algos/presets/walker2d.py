"""Walker2d's presets: within 1 M env steps (NPG; TRPO at Tianshou's settings) and fast on one GPU
(PPO). Scores: BENCHMARKS.md, "The suite within 1 M env steps" and "The suite on one GPU, fast"."""

from __future__ import annotations

from jaxpg.algos.presets.recipes import NPG_1M, PPO_LARGE_BATCH, TRPO_TIANSHOU
from jaxpg.algos.presets.row import Preset, Rows

ROWS: Rows = {
    # NPG within 1 M env steps: NPG_1M at initial log-std 0.75, the best of the settings screened
    # over 16 seeds.
    ("npg", "walker2d_1m"): Preset(tasks=("walker2d",), overrides={**NPG_1M, "log_std_init": 0.75}, iterations=120),
    # Within 1 M env steps at Tianshou's TRPO settings.
    ("trpo", "walker2d_1m"): Preset(tasks=("walker2d",), overrides=TRPO_TIANSHOU, iterations=976),
    # The least wall clock to the target on one GPU: PPO_LARGE_BATCH, the mean policy evaluated
    # about ten times a run; the iterations are where the measured runs stopped.
    ("ppo", "walker2d_fast"): Preset(
        tasks=("walker2d",), overrides={**PPO_LARGE_BATCH, "eval_every": 60}, iterations=660
    ),
}
