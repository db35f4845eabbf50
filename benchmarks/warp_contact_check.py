"""MuJoCo Warp against MJX's JAX implementation on the tasks whose observation holds contact forces.

For each task, ``--envs`` envs are reset with the same keys in both implementations (fidelity
"fast", float32) and stepped with the same uniform random actions for ``--steps`` env steps, each
implementation in one jitted ``lax.scan``. Printed per task: the largest difference in the
observation after the first step and over all steps (the two implementations part as contacts are
solved differently, so only the first steps are expected to agree closely), the mean norm of the
contact-force part of the observation in each implementation (zero would mean the forces were
never computed), and the fraction of env steps MuJoCo Warp flagged as overflowing (solver
iterations, contact or constraint capacity).

    python benchmarks/warp_contact_check.py --tasks ant humanoid --envs 4096 --steps 50

Needs a GPU and warp-lang (``pip install -e '.[warp]'``); it also runs on the CPU, slowly.
"""

from __future__ import annotations

import argparse
import time

import jax
import numpy as np

from jaxpg import envs

# Where the contact forces sit in each task's observation: the last ``n`` entries.
CONTACT_FORCE_ENTRIES = {"ant": 78, "humanoid": 78}


def run(task: str, impl: str, num_envs: int, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """``(obs [steps, num_envs, obs_dim], overflow [steps, num_envs])`` of ``task`` in ``impl``
    from the resets of keys ``split(key(0), num_envs)`` under actions drawn from ``key(1)``."""
    env = envs.make(task, batch=num_envs, impl=impl)

    @jax.jit
    def rollout(reset_keys: jax.Array, action_key: jax.Array) -> tuple[jax.Array, jax.Array]:
        state = jax.vmap(env.reset)(reset_keys)

        def body(state: envs.State, key: jax.Array) -> tuple[envs.State, tuple[jax.Array, jax.Array]]:
            action = jax.random.uniform(key, (num_envs, env.action_size), minval=env.action_low, maxval=env.action_high)
            state = jax.vmap(env.step)(state, action)
            return state, (state.obs, state.metrics["physics_overflow"])

        return jax.lax.scan(body, state, jax.random.split(action_key, steps))[1]

    obs, overflow = rollout(jax.random.split(jax.random.key(0), num_envs), jax.random.key(1))
    return np.asarray(obs), np.asarray(overflow)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=list(CONTACT_FORCE_ENTRIES), choices=list(CONTACT_FORCE_ENTRIES))
    parser.add_argument("--envs", type=int, default=4096)
    parser.add_argument("--steps", type=int, default=50)
    args = parser.parse_args()
    print(f"devices: {jax.devices()}")
    rows = []
    for task in args.tasks:
        started = time.perf_counter()
        warp_obs, overflow = run(task, "warp", args.envs, args.steps)
        jax_obs, _ = run(task, "jax", args.envs, args.steps)
        forces = slice(-CONTACT_FORCE_ENTRIES[task], None)
        first = float(np.max(np.abs(warp_obs[0] - jax_obs[0])))
        every = float(np.max(np.abs(warp_obs - jax_obs)))
        warp_force = float(np.mean(np.linalg.norm(warp_obs[..., forces], axis=-1)))
        jax_force = float(np.mean(np.linalg.norm(jax_obs[..., forces], axis=-1)))
        rows.append((task, first, every, warp_force, jax_force, float(overflow.mean()), time.perf_counter() - started))
    print(f"\n{args.envs} envs, {args.steps} steps, fidelity fast, random actions")
    print("| task | max obs diff, step 1 | max obs diff, all steps | contact-force norm, warp | jax | overflow | s |")
    print("|---|---|---|---|---|---|---|")
    for task, first, every, warp_force, jax_force, overflow, seconds in rows:
        print(
            f"| {task} | {first:.2e} | {every:.2e} | {warp_force:.4f} | {jax_force:.4f} "
            f"| {overflow:.4f} | {seconds:.0f} |"
        )


if __name__ == "__main__":
    main()
