"""The command jaxpg is known by, timed as a user runs it, then judged in Gymnasium.

For each seed this runs, as a separate process, exactly

    python experiments/hopper.py --num-envs 256 --seed S --run-dir RUN

(no other flag), timing the whole process (imports, MuJoCo Warp kernels, XLA compilation,
training, evaluations, checkpoints), then

    python -m jaxpg.evaluate RUN --gymnasium --episodes 10

and prints, per seed: wall clock, env steps, the last in-run mean-policy return and the mean
return in Gymnasium's CPU Hopper-v5. ``--cold`` gives every run empty caches (its own XLA
compilation cache and MuJoCo Warp kernel cache, as on a fresh machine); ``--warm`` runs again
with caches that a first run filled.

    python benchmarks/card_command.py --seeds 0 1 2 --modes cold warm --json card.json
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent


def train_once(seed: int, run_dir: Path, caches: Path, log: Path, extra: list[str]) -> dict[str, Any]:
    """One training process, timed as a whole; returns the row without the Gymnasium score."""
    env = {
        **os.environ,
        "JAXPG_COMPILATION_CACHE": str(caches / "xla"),
        "WARP_CACHE_PATH": str(caches / "warp"),
        "PYTHONUNBUFFERED": "1",
    }
    command = [sys.executable, "experiments/hopper.py", "--num-envs", "256", "--seed", str(seed)]
    command += ["--run-dir", str(run_dir), *extra]
    start = time.perf_counter()
    with log.open("w") as out:
        status = subprocess.run(command, cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT).returncode
    wall = time.perf_counter() - start
    metrics = run_dir / "metrics.jsonl"
    rows = [json.loads(line) for line in metrics.read_text().splitlines() if line.strip()] if metrics.exists() else []
    evaluated = [r for r in rows if r.get("return_mean_policy") is not None]
    return {
        "seed": seed,
        "status": status,
        "wall_s": wall,
        "env_steps": rows[-1]["env_steps"] if rows else float("nan"),
        "iterations": len(rows),
        "in_run_mean_policy": evaluated[-1]["return_mean_policy"] if evaluated else None,
        "evaluations": len(evaluated),
        "eval_s": sum(r.get("eval_seconds") or 0.0 for r in rows),
        "log_tail": log.read_text().splitlines()[-6:],
    }


def start_gymnasium(run_dir: Path, log: Path) -> subprocess.Popen:
    """``python -m jaxpg.evaluate RUN --gymnasium --episodes 10`` in the background (CPU only, so
    it runs beside the next training process without touching the GPU)."""
    command = [sys.executable, "-m", "jaxpg.evaluate", str(run_dir), "--gymnasium", "--episodes", "10"]
    env = {**os.environ, "JAX_PLATFORMS": "cpu", "JAXPG_COMPILATION_CACHE": "off"}
    return subprocess.Popen(command, cwd=ROOT, env=env, stdout=log.open("w"), stderr=subprocess.STDOUT)


def gymnasium_score(log: Path) -> tuple[float | None, float | None]:
    """Mean and std of the returns that ``jaxpg.evaluate`` printed."""
    match = re.search(r"^return: ([-\d.]+) ± ([\d.]+)", log.read_text(), re.M)
    return (float(match.group(1)), float(match.group(2))) if match else (None, None)


def collect(pending: list, wait: bool) -> None:
    """Fill in the Gymnasium scores of the evaluations that have finished (all, with ``wait``)."""
    for row, gym_log, process in pending:
        if "gymnasium_return" in row or (not wait and process.poll() is None):
            continue
        process.wait()
        row["gymnasium_return"], row["gymnasium_std"] = gymnasium_score(gym_log)
        row["gymnasium_output"] = gym_log.read_text().splitlines()[-3:]
        print(f"  {row['mode']} seed {row['seed']}: Gymnasium {row['gymnasium_return']} ± {row['gymnasium_std']}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--modes", nargs="+", choices=("cold", "warm"), default=["cold", "warm"])
    parser.add_argument("--out", default=None, help="where runs and logs go (default: a temporary directory)")
    parser.add_argument("--json", default=None)
    parser.add_argument("--extra", nargs=argparse.REMAINDER, default=[], help="extra flags (not the card's command)")
    args = parser.parse_args()

    out = Path(args.out or tempfile.mkdtemp(prefix="card-"))
    out.mkdir(parents=True, exist_ok=True)
    shared_caches = out / "caches-warm"
    rows, pending = [], []
    for mode in args.modes:
        for seed in args.seeds:
            caches = out / f"caches-cold-{seed}" if mode == "cold" else shared_caches
            if mode == "cold":
                shutil.rmtree(caches, ignore_errors=True)
            run_dir = out / f"{mode}-seed{seed}"
            shutil.rmtree(run_dir, ignore_errors=True)
            row = {"mode": mode, **train_once(seed, run_dir, caches, out / f"{mode}-seed{seed}.log", args.extra)}
            rows.append(row)
            gym_log = out / f"{mode}-seed{seed}-gymnasium.log"
            pending.append((row, gym_log, start_gymnasium(run_dir, gym_log)))
            print(
                f"  {mode} seed {seed}: {row['wall_s']:.1f} s, {row['env_steps']:,.0f} env steps, in-run mean "
                f"policy {row['in_run_mean_policy']}, exit {row['status']}",
                flush=True,
            )
            if mode == "cold" and "warm" in args.modes and not shared_caches.exists():
                shutil.copytree(caches, shared_caches)  # the warm runs start from a first run's caches
            collect(pending, wait=False)
            if args.json:
                Path(args.json).write_text(json.dumps(rows, indent=1))
    collect(pending, wait=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    print("\n| mode | seed | wall clock s | env steps | evaluations (s) | in-run mean policy | Gymnasium Hopper-v5 |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        print(
            f"| {row['mode']} | {row['seed']} | {row['wall_s']:.1f} | {row['env_steps']:,.0f} | "
            f"{row['evaluations']} ({row['eval_s']:.1f}) | {row['in_run_mean_policy'] or float('nan'):.0f} | "
            f"{row['gymnasium_return'] or float('nan'):.0f} ± {row['gymnasium_std'] or float('nan'):.0f} |"
        )
    for mode in args.modes:
        walls = [r["wall_s"] for r in rows if r["mode"] == mode]
        gyms = [r["gymnasium_return"] or float("nan") for r in rows if r["mode"] == mode]
        print(f"{mode}: median wall clock {statistics.median(walls):.1f} s, Gymnasium min {min(gyms):.0f}")


if __name__ == "__main__":
    main()
