"""Each seed's final mean policy of RUN_DIR over Reacher-v5 episodes (reset seeds FIRST..FIRST+COUNT-1), closed
loop in Gymnasium, beside the best plans found for the same episodes (summary of the planners' logs).
usage: python eval40.py RUN_DIR SEEDS FIRST COUNT"""

import sys

import gymnasium as gym
import numpy as np

import jaxpg

run_dir, seeds = sys.argv[1], [int(s) for s in sys.argv[2].split(",")]
first, count = int(sys.argv[3]), int(sys.argv[4])
env = gym.make("Reacher-v5")
for seed in seeds:
    policy = jaxpg.load_policy(run_dir, seed=seed)
    rets = []
    for sd in range(first, first + count):
        obs, _ = env.reset(seed=sd)
        ret = 0.0
        for _ in range(50):
            obs, r, *_ = env.step(np.clip(np.asarray(policy(obs), np.float64), -1, 1))
            ret += r
        rets.append(ret)
    rets = np.array(rets)
    print(
        f"{run_dir} seed {seed}: mean {rets.mean():.4f} +- {rets.std(ddof=1) / np.sqrt(len(rets)):.4f} "
        f"over {count} episodes "
        f"({first}-{first + count - 1}); returns {np.round(rets, 4).tolist()}",
        flush=True,
    )
