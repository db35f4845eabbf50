"""Where a Reacher policy's return goes in Gymnasium's Reacher-v5: distance vs control cost, and the
distance at each step of the episode (mean over episodes)."""

import sys

import gymnasium as gym
import numpy as np

import jaxpg

run, seed, episodes = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) > 3 else 50
policy = jaxpg.load_policy(run, seed=seed)
env = gym.make("Reacher-v5")
dist, ctrl, rets = np.zeros((episodes, 50)), np.zeros((episodes, 50)), []
for ep in range(episodes):
    obs, _ = env.reset(seed=1000 + ep)
    for t in range(50):
        obs, r, term, trunc, info = env.step(policy(obs))
        dist[ep, t], ctrl[ep, t] = -info["reward_dist"], -info["reward_ctrl"]
    rets.append(-(dist[ep].sum() + ctrl[ep].sum()))
print(
    f"{run} seed {seed}: return {np.mean(rets):.3f} +- {np.std(rets) / np.sqrt(episodes):.3f}; "
    f"distance {dist.sum(1).mean():.3f}, control {ctrl.sum(1).mean():.3f}"
)
print("mean distance at steps 0,1,2,3,5,10,20,30,49:", np.round(dist.mean(0)[[0, 1, 2, 3, 5, 10, 20, 30, 49]], 4))
print("control cost at steps 0,1,2,3,5,10,20,30,49:", np.round(ctrl.mean(0)[[0, 1, 2, 3, 5, 10, 20, 30, 49]], 4))
print(
    "distance over steps 10-49:",
    round(dist[:, 10:].sum(1).mean(), 3),
    " control over steps 10-49:",
    round(ctrl[:, 10:].sum(1).mean(), 3),
)
