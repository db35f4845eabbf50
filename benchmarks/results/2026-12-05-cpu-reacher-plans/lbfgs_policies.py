"""Plans per Reacher-v5 episode started from several trained policies' own actions: L-BFGS-B on the exact
episode cost (adj.py) from each policy's closed-loop actions, each result replayed in Gymnasium.
usage: python lbfgs_policies.py FIRST_SEED COUNT RUN_DIR:SEED [RUN_DIR:SEED ...]"""

import sys
import time

from adj import env, improve, objective, policy_episode, replay

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
        res = improve(f, policy_episode(policy, sd)[0])
        found[name] = round(float(replay(sd, res.x.reshape(50, 2))[0]), 4)
    best = max(found, key=found.get)
    print(
        f"reset seed {sd}: plan {found[best]:.4f} in Gymnasium (from {best}); from each policy {found} "
        f"({time.time() - t0:.0f} s)",
        flush=True,
    )
