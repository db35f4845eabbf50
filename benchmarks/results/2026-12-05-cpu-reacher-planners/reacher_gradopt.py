"""A planner with the true model on Reacher-v5: for each episode's initial state, 50 actions improved by
gradient descent on the episode's cost through MJX (Gymnasium's own model and RK4, constraints left
out so that no solver loop is differentiated; the replay has the joint limit), then replayed open-loop
in Gymnasium. The env is deterministic after reset, so the best open-loop plan would be the best
policy; Adam finds a local optimum only, so this is no bound.

usage: python reacher_gradopt.py EPISODES STEPS RESTARTS LR [RUN_DIR SEED]
(EPISODES: comma-separated, episode e resets with seed 1000 + e; RUN_DIR SEED: start from that run's
policy's actions)"""

import copy
import sys
import time

import gymnasium as gym
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import optax
from mujoco import mjx

EPS = [int(e) for e in sys.argv[1].split(",")]
STEPS = int(sys.argv[2]) if len(sys.argv) > 2 else 1500
RESTARTS = int(sys.argv[3]) if len(sys.argv) > 3 else 4
env = gym.make("Reacher-v5")
m = env.unwrapped.model
m_free = copy.deepcopy(m)  # no constraints: no solver loop to differentiate; the replay has the joint limit
m_free.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
mx = mjx.put_model(m_free)


def fingertip(q: jax.Array) -> jax.Array:
    """Fingertip x, y of Reacher's two links (0.1 and 0.11 long) at joint angles q[:2]."""
    return jnp.stack(
        [0.1 * jnp.cos(q[0]) + 0.11 * jnp.cos(q[0] + q[1]), 0.1 * jnp.sin(q[0]) + 0.11 * jnp.sin(q[0] + q[1])]
    )


def cost(u: jax.Array, qpos0: jax.Array, qvel0: jax.Array) -> jax.Array:
    """Episode cost of actions tanh(u) [50, 2] from (qpos0, qvel0)."""
    a_all = jnp.tanh(u)
    d0 = mjx.make_data(mx).replace(qpos=qpos0, qvel=qvel0)

    def step(d: mjx.Data, a: jax.Array) -> tuple[mjx.Data, jax.Array]:
        d = d.replace(ctrl=a)
        d = mjx.step(mx, mjx.step(mx, d))
        diff = fingertip(d.qpos) - d.qpos[2:4]
        return d, jnp.sqrt(jnp.sum(diff**2) + 1e-12) + jnp.sum(a**2)

    _, c = jax.lax.scan(step, d0, a_all)
    return c.sum()


opt = optax.adam(float(sys.argv[4]) if len(sys.argv) > 4 else 0.05)


@jax.jit
def solve(u0: jax.Array, qpos0: jax.Array, qvel0: jax.Array) -> tuple[jax.Array, jax.Array]:
    """STEPS of Adam on cost from u0; the final u and its cost."""

    def body(carry: tuple, _: None) -> tuple:
        u, s = carry
        c, g = jax.value_and_grad(cost)(u, qpos0, qvel0)
        upd, s = opt.update(g, s)
        return (optax.apply_updates(u, upd), s), c

    (u, _), _ = jax.lax.scan(body, (u0, opt.init(u0)), None, length=STEPS)
    return u, cost(u, qpos0, qvel0)


solve_all = jax.jit(jax.vmap(solve))
rng = np.random.default_rng(0)
q0s, v0s = [], []
for ep in EPS:
    env.reset(seed=1000 + ep)
    q0s.append(env.unwrapped.data.qpos.copy())
    v0s.append(env.unwrapped.data.qvel.copy())
best = {}
t0 = time.time()
for r in range(RESTARTS):
    if r == 0 and len(sys.argv) > 5:  # warm start: a trained policy's actions on the same episodes
        import jaxpg

        policy = jaxpg.load_policy(sys.argv[5], seed=int(sys.argv[6]))
        u0 = []
        for ep in EPS:
            obs, _ = env.reset(seed=1000 + ep)
            acts = []
            for _t in range(50):
                a = np.clip(policy(obs), -0.995, 0.995)
                acts.append(np.arctanh(a))
                obs, *_ = env.step(a)
            u0.append(acts)
        u0 = np.asarray(u0)
    else:
        u0 = np.zeros((len(EPS), 50, 2)) if r == 0 else rng.normal(0, 0.5, (len(EPS), 50, 2))
    us, cs = solve_all(jnp.asarray(u0), jnp.asarray(np.stack(q0s)), jnp.asarray(np.stack(v0s)))
    for i, ep in enumerate(EPS):
        if ep not in best or cs[i] < best[ep][1]:
            best[ep] = (np.asarray(us[i]), float(cs[i]))
    print(f"restart {r}: {time.time() - t0:.0f} s, model costs {np.round(np.asarray(cs), 3)}", flush=True)
rets = []
for ep in EPS:
    env.reset(seed=1000 + ep)
    tot = 0.0
    for a in np.tanh(best[ep][0]):
        _, rew, *_ = env.step(a)
        tot += rew
    rets.append(tot)
    print(f"episode {ep}: Gymnasium return {tot:.3f} (model {-best[ep][1]:.3f})")
print(f"mean {np.mean(rets):.3f} +- {np.std(rets) / np.sqrt(len(rets)):.3f} over {len(rets)} episodes")
