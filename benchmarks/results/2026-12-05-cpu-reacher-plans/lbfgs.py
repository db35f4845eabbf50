"""Best open-loop plan per Reacher-v5 episode: L-BFGS-B on the exact episode cost (MuJoCo's own physics, the
adjoint of its finite-difference linearisation), from several starts: the trained policy's own actions, zero
actions, and four pushes (each joint's sign) for the first 8 steps; the best plan replayed in Gymnasium.
usage: python lbfgs.py FIRST_SEED COUNT RUN_DIR SEED"""

import sys
import time

import numpy as np
from adj import env, improve, objective, policy_episode, replay

import jaxpg

first, count, run_dir, pseed = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], int(sys.argv[4])
policy = jaxpg.load_policy(run_dir, seed=pseed)
rows = []
t0 = time.time()
for sd in range(first, first + count):
    env.reset(seed=sd)
    q0, v0 = env.unwrapped.data.qpos.copy(), env.unwrapped.data.qvel.copy()
    d0 = float(np.linalg.norm(env.unwrapped.get_body_com("fingertip") - env.unwrapped.get_body_com("target")))
    acts, pol_ret = policy_episode(policy, sd)
    starts = [("policy", acts), ("zero", np.zeros((50, 2)))]
    for s0 in (-1, 1):
        for s1 in (-1, 1):
            x = np.zeros((50, 2))
            x[:8] = [0.5 * s0, 0.5 * s1]
            starts.append((f"push {s0:+d}{s1:+d}", x))
    f = objective(q0, v0)
    found = {}
    best = None
    for name, x0 in starts:
        res = improve(f, x0)
        found[name] = round(-res.fun, 3)
        if best is None or res.fun < best.fun:
            best, best_name = res, name
    plan = best.x.reshape(50, 2)
    ret, dists = replay(sd, plan)
    rows.append((sd, ret, pol_ret, d0, dists[-1]))
    print(
        f"reset seed {sd}: plan {ret:.4f} in Gymnasium, policy {pol_ret:.4f} (best start: {best_name}; {found}) "
        f"start distance {d0:.3f}, plan's control {np.sum(plan**2):.3f}, distance {sum(dists):.3f}, "
        f"final {dists[-1]:.4f} ({time.time() - t0:.0f} s)",
        flush=True,
    )
r = np.array([x[1] for x in rows])
p = np.array([x[2] for x in rows])
d0 = np.array([x[3] for x in rows])
dl = np.array([x[4] for x in rows])
print(
    f"{len(r)} episodes: plans {r.mean():.4f} +- {r.std(ddof=1) / np.sqrt(len(r)):.4f}; policy {p.mean():.4f}; "
    f"plan minus policy {np.mean(r - p):.4f} +- {np.std(r - p, ddof=1) / np.sqrt(len(r)):.4f}; "
    f"mean start distance {d0.mean():.4f}; "
    f"the plans as Reacher-v2 counts (distance before each step): {(r - d0 + dl).mean():.4f}"
)
