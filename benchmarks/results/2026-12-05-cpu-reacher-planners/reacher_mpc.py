"""Model-predictive control on Gymnasium's Reacher-v5 with the true model: at each step the cross-entropy
method over open-loop action sequences of H steps, rolled out with MuJoCo's own rollout.

usage: POP=512 ELITE=32 ITERS=8 python reacher_mpc.py H EPISODES (episode e resets with seed 1000 + e)"""

import os
import sys

import gymnasium as gym
import mujoco
import numpy as np
from mujoco import rollout

H = int(sys.argv[1]) if len(sys.argv) > 1 else 12
POP, ELITE, ITERS = int(os.environ.get("POP", 256)), int(os.environ.get("ELITE", 24)), int(os.environ.get("ITERS", 5))
env = gym.make("Reacher-v5")
m = env.unwrapped.model
spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
nstate = mujoco.mj_stateSize(m, spec)
datas = [mujoco.MjData(m)]


def fingertip(qpos: np.ndarray) -> np.ndarray:
    """Fingertip x, y of Reacher's two links (0.1 and 0.11 long) at joint angles qpos[..., :2]."""
    a0, a1 = qpos[..., 0], qpos[..., 1]
    x = 0.1 * np.cos(a0) + 0.11 * np.cos(a0 + a1)
    y = 0.1 * np.sin(a0) + 0.11 * np.sin(a0 + a1)
    return np.stack([x, y], -1)


def cost(state0: np.ndarray, seqs: np.ndarray) -> np.ndarray:
    """Episode cost (distance + control) of each action sequence [POP, h, 2] from state0."""
    ctrl = np.repeat(seqs, 2, axis=1)  # frame skip 2
    st, _ = rollout.rollout(m, datas, state0[None], ctrl)
    qpos = st[:, 1::2, 1 : 1 + m.nq]  # state after each env step
    d = np.linalg.norm(fingertip(qpos) - qpos[..., 2:4], axis=-1)
    return d.sum(1) + (seqs**2).sum((1, 2))


rets, rng = [], np.random.default_rng(0)
EPS = [int(e) for e in sys.argv[2].split(",")]
for ep in EPS:
    obs, _ = env.reset(seed=1000 + ep)
    mean = np.zeros((H, 2))
    std = np.full((H, 2), 0.6)
    total = 0.0
    for t in range(50):
        s0 = np.empty(nstate)
        mujoco.mj_getState(m, env.unwrapped.data, s0, spec)
        h = min(H, 50 - t)
        mu, sd = mean[:h].copy(), std[:h].copy()
        for _ in range(ITERS):
            seqs = np.clip(mu + sd * rng.standard_normal((POP, h, 2)), -1, 1)
            seqs[0] = np.clip(mu, -1, 1)
            c = cost(s0, seqs)
            el = seqs[np.argsort(c)[:ELITE]]
            mu, sd = el.mean(0), el.std(0) + 0.02
        a = np.clip(mu[0], -1, 1)
        obs, r, term, trunc, info = env.step(a)
        total += r
        mean = np.concatenate([mu[1:], np.zeros((1, 2))])
        mean = np.pad(mean, ((0, H - len(mean)), (0, 0)))
        std = np.full((H, 2), 0.6)
    rets.append(total)
    print(f"episode {ep}: {total:.3f}", flush=True)
print(f"H={H}: mean {np.mean(rets):.3f} +- {np.std(rets) / np.sqrt(len(rets)):.3f} over {len(rets)} episodes")
