"""Time to solve InvertedPendulum on the CPU: jaxpg's NPG beside Stable-Baselines3's PPO.

"Solved" is a deterministic (mean-policy) evaluation return >= ``--target`` (950 of 1000). Every
run is a fresh process whose clock starts before it imports its framework, and includes
compilation and every evaluation:

  jaxpg NPG, cold   ``time_to_return.py run --task inverted_pendulum --algo npg --preset pendulum_cpu``
                    with the persistent compilation cache off: every program is compiled;
  jaxpg NPG, warm   the same with the cache on, after a warm-up run has filled it (the second
                    run of a program on a machine);
  SB3 PPO           Stable-Baselines3's PPO with its defaults on Gymnasium's InvertedPendulum-v5,
                    evaluated every 8192 steps over 10 deterministic episodes (the usual way
                    SB3's figures for this task are taken), torch on ``--threads`` threads.

jaxpg's runs evaluate 10 episodes every 5 iterations (20480 samples). Both need nothing else
running on the machine. SB3 is optional (``pip install stable-baselines3 torch``); without it,
its rows are skipped.

    python benchmarks/cpu_pendulum.py --seeds 0 1 2 --json cpu_pendulum.json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import harness

HERE = os.path.dirname(os.path.abspath(__file__))


def jaxpg_runs(seeds: list[int], target: float, cache: str | None, warmup: bool) -> list[dict]:
    """``time_to_return.py`` rows for NPG on the pendulum (``cache``: a directory, or None: off)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "rows.json")
        cmd = [sys.executable, os.path.join(HERE, "time_to_return.py"), "run", "--task", "inverted_pendulum"]
        cmd += ["--algo", "npg", "--preset", "pendulum_cpu", "--impl", "jax", "--target", str(target)]
        cmd += ["--eval-envs", "10", "--block", "5", "--max-seconds", "180", "--json", out, "--seeds"]
        cmd += [str(s) for s in seeds] + (["--warmup"] if warmup else [])
        env = {**os.environ, "JAXPG_COMPILATION_CACHE": cache or "off", "JAX_PLATFORMS": "cpu"}
        subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL)
        return harness.rows_of(out)


def sb3_single(seed: int, target: float, threads: int, max_steps: int) -> dict:
    """One Stable-Baselines3 PPO run (this process): seconds and steps to a deterministic
    10-episode evaluation return >= ``target``."""
    start = time.perf_counter()
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import EvalCallback, StopTrainingOnRewardThreshold

    torch.set_num_threads(threads)
    stop = StopTrainingOnRewardThreshold(reward_threshold=target, verbose=0)
    evaluation = EvalCallback(
        gym.make("InvertedPendulum-v5"),
        n_eval_episodes=10,
        eval_freq=8192,
        deterministic=True,
        callback_on_new_best=stop,
        verbose=0,
    )
    model = PPO("MlpPolicy", gym.make("InvertedPendulum-v5"), seed=seed, verbose=0, device="cpu")
    model.learn(total_timesteps=max_steps, callback=evaluation)
    seconds = time.perf_counter() - start
    reached = evaluation.best_mean_reward >= target
    return {
        "seed": seed,
        "reached": bool(reached),
        "seconds": seconds if reached else None,
        "env_steps": int(model.num_timesteps),
        "best_return": float(evaluation.best_mean_reward),
        "wall_s": seconds,
    }


def sb3_runs(seeds: list[int], target: float, threads: int, max_steps: int) -> list[dict] | None:
    """``sb3_single`` for each seed in a fresh process; None when SB3 is not installed."""
    try:
        import stable_baselines3  # noqa: F401
    except ImportError:
        return None
    rows = []
    for seed in seeds:
        cmd = [sys.executable, __file__, "--sb3-single", str(seed), "--target", str(target)]
        cmd += ["--threads", str(threads), "--sb3-max-steps", str(max_steps)]
        proc = subprocess.run(cmd, capture_output=True, text=True, check=True)
        rows.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    return rows


def summary(name: str, rows: list[dict]) -> str:
    """One markdown row: per-seed seconds (steps) and the median."""
    cells = [f"{r['seconds']:.1f} s ({r['env_steps'] / 1e3:.0f} k)" if r["reached"] else "not solved" for r in rows]
    times = [r["seconds"] for r in rows if r["reached"]]
    median = f"**{statistics.median(times):.1f} s**" if len(times) == len(rows) else "-"
    return f"| {name} | {' | '.join(cells)} | {median} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--target", type=float, default=950.0)
    parser.add_argument("--threads", type=int, default=2, help="torch threads for SB3")
    parser.add_argument("--sb3-max-steps", type=int, default=200_000)
    parser.add_argument("--no-sb3", action="store_true", help="skip the Stable-Baselines3 baseline")
    parser.add_argument("--json", help="write all rows here")
    parser.add_argument("--sb3-single", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.sb3_single is not None:
        print(json.dumps(sb3_single(args.sb3_single, args.target, args.threads, args.sb3_max_steps)))
        return

    results = {"cpu_count": os.cpu_count()}
    results["jaxpg_cold"] = jaxpg_runs(args.seeds, args.target, cache=None, warmup=False)
    with tempfile.TemporaryDirectory() as cache:
        results["jaxpg_warm"] = jaxpg_runs(args.seeds, args.target, cache=cache, warmup=True)
    results["sb3_ppo"] = None if args.no_sb3 else sb3_runs(args.seeds, args.target, args.threads, args.sb3_max_steps)

    seeds = " | ".join(f"seed {s}" for s in args.seeds)
    print(f"\ninverted_pendulum, time to a deterministic return >= {args.target:g}, {os.cpu_count()} CPU cores")
    print(f"| run | {seeds} | median |")
    print("|---|" + "---|" * (len(args.seeds) + 1))
    print(summary("jaxpg NPG `pendulum_cpu`, compilation cache cold", results["jaxpg_cold"]))
    print(summary("jaxpg NPG `pendulum_cpu`, compilation cache warm", results["jaxpg_warm"]))
    if results["sb3_ppo"] is not None:
        print(summary("Stable-Baselines3 PPO, defaults", results["sb3_ppo"]))
    harness.write_json(args.json, results, target=args.target)


if __name__ == "__main__":
    main()
