"""Each seed's final mean policy of RUN_DIR over Reacher-v5 episodes (reset seeds FIRST..FIRST+COUNT-1), closed
loop in Gymnasium (compare_policies.py sets them beside the plans).
usage: python eval40.py RUN_DIR SEEDS FIRST COUNT"""

import sys

import numpy as np
from adj import policy_episode

import jaxpg

run_dir, seeds = sys.argv[1], [int(s) for s in sys.argv[2].split(",")]
first, count = int(sys.argv[3]), int(sys.argv[4])
for seed in seeds:
    policy = jaxpg.load_policy(run_dir, seed=seed)
    rets = np.array([policy_episode(policy, sd)[1] for sd in range(first, first + count)])
    print(
        f"{run_dir} seed {seed}: mean {rets.mean():.4f} +- {rets.std(ddof=1) / np.sqrt(len(rets)):.4f} "
        f"over {count} episodes "
        f"({first}-{first + count - 1}); returns {np.round(rets, 4).tolist()}",
        flush=True,
    )
