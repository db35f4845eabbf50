"""Plans per Reacher-v5 episode started from several trained policies' own actions: L-BFGS-B on the exact
episode cost (adj.py) from each policy's closed-loop actions, each result replayed in Gymnasium.
usage: python lbfgs_policies.py FIRST_SEED COUNT RUN_DIR:SEED [RUN_DIR:SEED ...]"""

import sys
import time

import numpy as np
import scipy.optimize as so
from adj import env, objective

import jaxpg

first, count = int(sys.argv[1]), int(sys.argv[2])
policies = {}
for spec in sys.argv[3:]:
    run_dir, seed = spec.rsplit(":", 1)
    policies[spec] = jaxpg.load_policy(run_dir, seed=int(seed))
t0 = time.time()
for sd in range(first, first + count):
    env.reset(seed=sd)
    q0, v0 = env.unwrapped.data.qpos.copy(), env.unwrapped.data.qvel.copy()
    f = objective(q0, v0)
    found = {}
    for name, policy in policies.items():
        obs, _ = env.reset(seed=sd)
        acts = []
        for _ in range(50):
            a = np.clip(np.asarray(policy(obs), np.float64), -1, 1)
            acts.append(a)
            obs, *_ = env.step(a)
        res = so.minimize(
            f,
            np.asarray(acts).ravel(),
            jac=True,
            method="L-BFGS-B",
            bounds=[(-1, 1)] * 100,
            options={"maxiter": 600, "ftol": 1e-12, "gtol": 1e-8},
        )
        env.reset(seed=sd)
        found[name] = round(float(sum(env.step(a)[1] for a in res.x.reshape(50, 2))), 4)
    best = max(found, key=found.get)
    print(
        f"reset seed {sd}: plan {found[best]:.4f} in Gymnasium (from {best}); from each policy {found} "
        f"({time.time() - t0:.0f} s)",
        flush=True,
    )
