"""Does the best plan keep improving with more starts? Per Reacher-v5 episode, L-BFGS-B (adj.py) from the
trained policy's actions, zero actions, pushes of each sign pattern (0.3 and 0.8 for the first 5 and 10 steps)
and uniform random actions (scales 0.1, 0.3, 0.6), printing the best return after 1, 2, 4, 8, 16 and all starts,
each replayed in Gymnasium. usage: python lbfgs_many.py FIRST_SEED COUNT RUN_DIR SEED RANDOM_STARTS"""

import sys
import time

import numpy as np
from adj import env, improve, objective, policy_episode, replay

import jaxpg

first, count, run_dir, pseed, nrand = (
    int(sys.argv[1]),
    int(sys.argv[2]),
    sys.argv[3],
    int(sys.argv[4]),
    int(sys.argv[5]),
)
policy = jaxpg.load_policy(run_dir, seed=pseed)
rng = np.random.default_rng(first)
t0 = time.time()
for sd in range(first, first + count):
    env.reset(seed=sd)
    q0, v0 = env.unwrapped.data.qpos.copy(), env.unwrapped.data.qvel.copy()
    acts, pol_ret = policy_episode(policy, sd)
    starts = [acts, np.zeros((50, 2))]
    for mag, steps in ((0.3, 10), (0.8, 5)):
        for s0 in (-1, 1):
            for s1 in (-1, 1):
                x = np.zeros((50, 2))
                x[:steps] = [mag * s0, mag * s1]
                starts.append(x)
    starts += [rng.uniform(-1, 1, (50, 2)) * [0.1, 0.3, 0.6][i % 3] for i in range(nrand)]
    f = objective(q0, v0)
    found = []
    for x0 in starts:
        res = improve(f, x0)
        found.append(replay(sd, res.x.reshape(50, 2))[0])
    found = np.array(found)
    order = np.random.default_rng(sd).permutation(len(found))  # best of k starts drawn at random
    curve = {k: round(float(np.max(found[order[:k]])), 4) for k in (1, 2, 4, 8, 16, len(found))}
    print(
        f"reset seed {sd}: plan {found.max():.4f} in Gymnasium, policy {pol_ret:.4f}; "
        f"the policy's start {found[0]:.4f}, "
        f"best of k random-order starts {curve} ({time.time() - t0:.0f} s)",
        flush=True,
    )
