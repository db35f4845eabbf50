"""Exact Gymnasium Reacher-v5 episode cost and its gradient by the adjoint of MuJoCo's linearised steps.

``python adj.py``: the cost against Gymnasium's own return, the gradient against central differences, and
the time of one gradient."""

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
import scipy.optimize as so

env = gym.make("Reacher-v5")
m = env.unwrapped.model
d = mujoco.MjData(m)
nv = m.nv


def tip_and_jac(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The fingertip's x, y [2] at joint angles q[:2] (links 0.1 and 0.11 long) and its Jacobian [2, 2]."""
    c0, s0 = np.cos(q[0]), np.sin(q[0])
    c01, s01 = np.cos(q[0] + q[1]), np.sin(q[0] + q[1])
    p = np.array([0.1 * c0 + 0.11 * c01, 0.1 * s0 + 0.11 * s01])
    J = np.array([[-0.1 * s0 - 0.11 * s01, -0.11 * s01], [0.1 * c0 + 0.11 * c01, 0.11 * c01]])
    return p, J


spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
nstate = mujoco.mj_stateSize(m, spec)
scratch = mujoco.MjData(m)


def linearise(a: np.ndarray, eps: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """A [4, 4], B [4, 2]: the env step's (two substeps) derivative in the arm's (q0, q1, v0, v1)."""
    s0 = np.empty(nstate)
    mujoco.mj_getState(m, d, s0, spec)

    def two_steps(s: np.ndarray, ctrl: np.ndarray) -> np.ndarray:
        mujoco.mj_setState(m, scratch, s, spec)
        scratch.ctrl[:] = ctrl
        mujoco.mj_step(m, scratch)
        mujoco.mj_step(m, scratch)
        return np.array([scratch.qpos[0], scratch.qpos[1], scratch.qvel[0], scratch.qvel[1]])

    base = two_steps(s0, a)
    A = np.empty((4, 4))
    B = np.empty((4, 2))
    # FULLPHYSICS state: time, qpos (4), qvel (4), act, ...
    idx = [1 + 0, 1 + 1, 1 + nv + 0, 1 + nv + 1]
    for j, i in enumerate(idx):
        s = s0.copy()
        s[i] += eps
        A[:, j] = (two_steps(s, a) - base) / eps
    for k in range(2):
        ak = a.copy()
        ak[k] += eps
        B[:, k] = (two_steps(s0, ak) - base) / eps
    return A, B


def set_state(qpos: np.ndarray, qvel: np.ndarray) -> None:
    """Put the episode's start into ``d``."""
    d.qpos[:] = qpos
    d.qvel[:] = qvel
    d.time = 0.0
    d.act[:] = 0
    d.qacc_warmstart[:] = 0
    mujoco.mj_forward(m, d)


def cost_grad(
    u: np.ndarray, qpos0: np.ndarray, qvel0: np.ndarray, grad: bool = True
) -> tuple[float, np.ndarray | None]:
    """u [50, 2] -> (cost, dcost/du [50, 2])."""
    set_state(qpos0, qvel0)
    As, Bs, gxs = [], [], []
    total = 0.0
    gu = 2 * u.copy()
    for t in range(50):
        d.ctrl[:] = u[t]
        if grad:
            A, B = linearise(u[t])
        mujoco.mj_step(m, d)
        mujoco.mj_step(m, d)
        q = d.qpos
        p, J = tip_and_jac(q)
        diff = p - q[2:4]
        dist = np.sqrt(diff @ diff + 1e-14)
        total += dist + u[t] @ u[t]
        if grad:
            gx = np.zeros(2 * nv)
            g = diff / dist
            gx[0:2] = J.T @ g
            gx[2:4] = -g
            As.append(A)
            Bs.append(B)
            gxs.append(gx[[0, 1, 4, 5]])
    if not grad:
        return total, None
    lam = np.zeros(4)  # dJ/dx_{t+1} accumulated from the future
    for t in range(49, -1, -1):
        lam = lam + gxs[t]  # cost at x_{t+1}
        gu[t] += Bs[t].T @ lam
        lam = As[t].T @ lam
    return total, gu


def objective(qpos0: np.ndarray, qvel0: np.ndarray) -> Callable[[np.ndarray], tuple[float, np.ndarray]]:
    """``x [100] -> (cost, gradient [100])`` of the episode from ``(qpos0, qvel0)``, for scipy."""

    def f(x: np.ndarray) -> tuple[float, np.ndarray]:
        c, g = cost_grad(x.reshape(50, 2), qpos0, qvel0)
        return c, g.ravel()

    return f


def improve(
    f: Callable[[np.ndarray], tuple[float, np.ndarray]], x0: np.ndarray, maxiter: int = 600, ftol: float = 1e-12
) -> so.OptimizeResult:
    """L-BFGS-B on ``f`` (``objective``'s) from actions ``x0`` [50, 2] or [100], within [-1, 1]."""
    return so.minimize(
        f,
        np.ravel(x0),
        jac=True,
        method="L-BFGS-B",
        bounds=[(-1, 1)] * 100,
        options={"maxiter": maxiter, "ftol": ftol, "gtol": 1e-8},
    )


def replay(seed: int, actions: np.ndarray) -> tuple[float, list[float]]:
    """Actions [50, 2] played in Gymnasium from reset ``seed``: the return and the distance after each step."""
    env.reset(seed=seed)
    dists, ret = [], 0.0
    for a in actions:
        _, r, _, _, info = env.step(a)
        ret += r
        dists.append(-info["reward_dist"])
    return ret, dists


def policy_episode(policy: Callable[[np.ndarray], Any], seed: int) -> tuple[np.ndarray, float]:
    """A trained policy played closed loop from reset ``seed`` (its actions clipped to [-1, 1]): its
    actions [50, 2] and its return."""
    obs, _ = env.reset(seed=seed)
    acts, ret = [], 0.0
    for _ in range(50):
        a = np.clip(np.asarray(policy(obs), np.float64), -1, 1)
        acts.append(a)
        obs, r, *_ = env.step(a)
        ret += r
    return np.asarray(acts), ret


if __name__ == "__main__":
    import time

    env.reset(seed=1000)
    q0, v0 = env.unwrapped.data.qpos.copy(), env.unwrapped.data.qvel.copy()
    rng = np.random.default_rng(0)
    u = rng.uniform(-0.5, 0.5, (50, 2))
    c, g = cost_grad(u, q0, v0)
    env.reset(seed=1000)
    print("cost", c, "gym", -sum(env.step(a)[1] for a in u))
    for t, k in [(0, 0), (10, 1), (30, 0), (49, 1)]:
        e = np.zeros_like(u)
        e[t, k] = 1e-6
        fd = (cost_grad(u + e, q0, v0, False)[0] - cost_grad(u - e, q0, v0, False)[0]) / 2e-6
        print(t, k, g[t, k], fd)
    t0 = time.time()
    for _ in range(20):
        cost_grad(u, q0, v0)
    print("per gradient", (time.time() - t0) / 20)
