"""jaxpg's tasks through the Gymnasium API: Stable-Baselines3 trains on them, and how fast they step.

sb3         Stable-Baselines3 PPO (its defaults) on ``jaxpg/InvertedPendulum-v5`` through
            ``jaxpg.envs.gymnasium_env``, then its deterministic policy on 10 episodes of
            jaxpg's env and of Gymnasium's own ``InvertedPendulum-v5``.
throughput  env steps/s under random actions, NumPy in and out: ``gymnasium_vector_env`` at
            each ``--num-envs``, against Gymnasium's own MuJoCo vector env
            (``gymnasium.make_vec(..., vectorization_mode="sync"|"async")``) on the CPU.
single      one env of each ``--ids`` as a Gymnasium user makes it (``gymnasium.make(id)``): the
            seconds of its first ``make`` + ``reset`` + ``step`` (jaxpg's: compilation) and its
            env steps/s after that, under random actions.

  python benchmarks/gymnasium_api.py sb3 --steps 100000
  python benchmarks/gymnasium_api.py throughput --task hopper --num-envs 1024 4096 16384 --gym-envs 16
  python benchmarks/gymnasium_api.py single --ids jaxpg/Hopper-v5 jaxpg/HopperFast-v5 Hopper-v5 --steps 2000
"""

from __future__ import annotations

import argparse
import json
import os
import time
from typing import Any

import numpy as np

GYM_IDS = {"hopper": "Hopper-v5", "inverted_pendulum": "InvertedPendulum-v5"}


def evaluate_sb3(model: Any, env: Any, episodes: int, seed: int) -> tuple[float, float]:
    """Mean and std of the deterministic policy's episode returns."""
    returns = []
    for episode in range(episodes):
        obs, _ = env.reset(seed=seed + episode)
        total, done = 0.0, False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            done = terminated or truncated
        returns.append(total)
    return float(np.mean(returns)), float(np.std(returns))


def run_sb3(steps: int, seed: int) -> dict[str, Any]:
    import gymnasium
    from stable_baselines3 import PPO

    from jaxpg import envs

    env = envs.gymnasium_env("inverted_pendulum")
    model = PPO("MlpPolicy", env, seed=seed, verbose=0, device="cpu")
    start = time.perf_counter()
    model.learn(total_timesteps=steps)
    train_s = time.perf_counter() - start
    ours = evaluate_sb3(model, env, 10, 1000)
    theirs = evaluate_sb3(model, gymnasium.make("InvertedPendulum-v5"), 10, 1000)
    row = {"steps": steps, "seed": seed, "train_s": train_s, "jaxpg_return": ours, "gymnasium_return": theirs}
    print(
        f"| SB3 PPO on jaxpg/InvertedPendulum-v5 | {steps:,} | {train_s:.0f} s | {steps / train_s:,.0f} | "
        f"{ours[0]:.0f} ± {ours[1]:.0f} | {theirs[0]:.0f} ± {theirs[1]:.0f} |"
    )
    return row


def steps_per_second(env: Any, steps: int, seed: int = 0) -> float:
    """Random in-range actions (drawn on the host, as a Gymnasium user would), after a warm-up."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    space = env.action_space
    low, high = space.low, space.high
    actions = [rng.uniform(low, high).astype(np.float32) for _ in range(min(steps, 64))]
    for a in actions[:3]:  # compile / start workers
        env.step(a)
    start = time.perf_counter()
    for t in range(steps):
        env.step(actions[t % len(actions)])
    return steps * env.num_envs / (time.perf_counter() - start)


def run_throughput(task: str, num_envs: list[int], gym_envs: list[int], steps: int, impl: str | None) -> list[dict]:
    import gymnasium
    import jax

    from jaxpg import envs

    rows = []
    device = jax.devices()[0].device_kind
    for n in num_envs:
        vec = envs.gymnasium_vector_env(task, n, **({"impl": impl} if impl else {}))
        rate = steps_per_second(vec, steps)
        rows.append({"what": f"jaxpg gymnasium_vector_env ({vec.env.unwrapped.impl})", "envs": n, "rate": rate})
        print(f"| {rows[-1]['what']} | {device} | {n} | {rate / 1e3:,.1f} k |", flush=True)
    for mode in ("sync", "async"):
        for n in gym_envs:
            # Spawned workers: forking a process that runs JAX's threads can deadlock.
            extra = {"vector_kwargs": {"context": "spawn"}} if mode == "async" else {}
            vec = gymnasium.make_vec(GYM_IDS[task], num_envs=n, vectorization_mode=mode, **extra)
            rate = steps_per_second(vec, max(steps // 4, 50))
            vec.close()
            rows.append({"what": f"Gymnasium make_vec {mode} (MuJoCo, CPU)", "envs": n, "rate": rate})
            print(f"| {rows[-1]['what']} | {os.cpu_count()} CPU cores | {n} | {rate / 1e3:,.1f} k |", flush=True)
    return rows


def run_single(ids: list[str], steps: int) -> list[dict]:
    """First ``make`` + ``reset`` + ``step`` seconds and steps/s of one env of each id."""
    import gymnasium
    import jax

    import jaxpg.envs.gymnasium_api  # noqa: F401 - registers the jaxpg/ ids

    rows = []
    device = jax.devices()[0].device_kind
    for gym_id in ids:
        start = time.perf_counter()
        env = gymnasium.make(gym_id)
        env.action_space.seed(0)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        first_s = time.perf_counter() - start
        actions = [env.action_space.sample() for _ in range(64)]
        start = time.perf_counter()
        for t in range(steps):
            _, _, terminated, truncated, _ = env.step(actions[t % len(actions)])
            if terminated or truncated:
                env.reset()
        rate = steps / (time.perf_counter() - start)
        rows.append({"id": gym_id, "device": device, "first_s": first_s, "rate": rate})
        print(f"| {gym_id} | {device} | {first_s:.1f} s | {rate:,.0f} |", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mode", choices=("sb3", "throughput", "single"))
    parser.add_argument("--ids", nargs="*", default=["jaxpg/Hopper-v5", "jaxpg/HopperFast-v5", "Hopper-v5"])
    parser.add_argument("--steps", type=int, default=100_000, help="sb3: training steps; throughput: vector steps")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--task", default="hopper", choices=sorted(GYM_IDS))
    parser.add_argument("--num-envs", nargs="*", type=int, default=[1024, 4096])
    parser.add_argument("--gym-envs", nargs="*", type=int, default=[16])
    parser.add_argument("--impl", choices=("jax", "warp"), default=None)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    if args.mode == "sb3":
        print("| what | env steps | wall clock | env steps/s | jaxpg env (10 episodes) | Gymnasium env (10 episodes) |")
        print("|---|---|---|---|---|---|")
        result: Any = run_sb3(args.steps, args.seed)
    elif args.mode == "single":
        print("| id | device | first make + reset + step | env steps/s |")
        print("|---|---|---|---|")
        result = run_single(args.ids, args.steps)
    else:
        print("| what | device | envs | env steps/s |")
        print("|---|---|---|---|")
        result = run_throughput(args.task, args.num_envs, args.gym_envs, args.steps, args.impl)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
