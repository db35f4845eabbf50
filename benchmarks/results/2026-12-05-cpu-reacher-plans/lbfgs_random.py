"""Best open-loop plan per Reacher-v5 episode, from zero actions and random ones: L-BFGS-B on the exact episode
cost (adj.py), starts zero, then uniform in [-0.3, 0.3] and [-0.1, 0.1] alternately (generator seeded by
FIRST_SEED), the best plan replayed in Gymnasium. usage: python lbfgs_random.py FIRST_SEED COUNT STARTS"""

import sys
import time

import numpy as np
from adj import env, improve, objective, replay

first, count, starts = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
rng = np.random.default_rng(first)
rows = []
t0 = time.time()
for sd in range(first, first + count):
    env.reset(seed=sd)
    q0, v0 = env.unwrapped.data.qpos.copy(), env.unwrapped.data.qvel.copy()
    d0 = float(np.linalg.norm(env.unwrapped.get_body_com("fingertip") - env.unwrapped.get_body_com("target")))
    f = objective(q0, v0)
    results, best = [], None
    for s in range(starts):
        x0 = np.zeros(100) if s == 0 else rng.uniform(-1, 1, 100) * [0.1, 0.3][s % 2]
        res = improve(f, x0, maxiter=1500, ftol=1e-13)
        results.append(res.fun)
        if best is None or res.fun < best.fun:
            best = res
    acts = best.x.reshape(50, 2)
    ret, dists = replay(sd, acts)
    rows.append((sd, ret, d0, float(np.sum(acts**2)), sum(dists), dists[-1]))
    print(
        f"reset seed {sd}: Gymnasium {ret:.4f} (plan {-best.fun:.4f}; "
        f"starts {np.round(-np.array(results), 3).tolist()}) start distance {d0:.3f}, "
        f"control {np.sum(acts**2):.3f}, distance {sum(dists):.3f}, final distance {dists[-1]:.4f} "
        f"({time.time() - t0:.0f} s)",
        flush=True,
    )
r = np.array([x[1] for x in rows])
d0 = np.array([x[2] for x in rows])
dl = np.array([x[5] for x in rows])
print(
    f"mean Gymnasium return {r.mean():.4f} +- {r.std(ddof=1) / np.sqrt(len(r)):.4f} over {len(r)} episodes; "
    f"mean start distance {d0.mean():.4f}; as Reacher-v2 would count the same plans "
    f"(distance before each step): {(r - d0 + dl).mean():.4f}"
)
