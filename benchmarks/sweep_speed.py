"""One sweep against the same runs one process after another: GPU-seconds per run, runs per
GPU-hour, peak memory (docs/sweeps.md; GPU results go to BENCHMARKS.md).

    python benchmarks/sweep_speed.py --case npg --out results/sweep-speed
    python benchmarks/sweep_speed.py --case ppo --iterations 100 --out results/sweep-speed
    python benchmarks/sweep_speed.py --quick --out /tmp/sweep-speed     # CPU smoke test, tiny sizes

Cases: ``npg``, 64 configurations (kl_delta x gae_lambda, 8 x 8) x 4 seeds of ``hopper_1m`` on
Hopper; ``ppo``, 64 configurations (lr x clip_eps, 8 x 8) x 4 seeds of ``ant_1m`` on Ant. Each case:

- the sweep: ``jaxpg.sweep.run_sweep`` in this process, every run in one program, no scoring (the
  Gymnasium scores run on CPU workers beside the device and are left out of the device's time);
  timed from the call to its end, compilation included;
- the sequential sample: ``--sequential`` of the same runs (configurations spread over the grid,
  seed 0), each in a fresh Python process as a researcher running them one after another would:
  the static config (no traced hyperparameters), ``init`` and blocks of ``update`` jitted as the
  sweep's (the same iterations per call), timed from the process's start to its end (JAX start,
  env, compilation, training) and, separately, its training alone.

Both allocate device memory on demand (``XLA_PYTHON_CLIENT_PREALLOCATE=false``, as ``jaxpg.cli``),
and the sequential sample runs before the sweep, while this process holds no device memory.

Extrapolation: the sequential runs' mean process seconds times the sweep's run count is what the
sweep's runs would take one after another; the ratio of that to the sweep's seconds is the
speed-up (GPU-seconds per run, sequential / sweep). The same ratio of training seconds alone
(no JAX start, no compilation) is printed beside it: the speed-up a warm cache of compiled
programs would leave. Peak memory is the device allocator's peak (``peak_bytes_in_use``), or on
the CPU the process's peak resident memory.

Prints a table; writes ``sweep_speed.json`` under ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def cases(quick: bool, iterations: int | None) -> dict[str, Any]:
    """The sweep spec of each case (``--quick``: tiny sizes on cartpole)."""
    from jaxpg.sweep import SweepSpec

    if quick:
        small = {"num_envs": 4, "horizon": 16, "policy_hidden": [8], "value_hidden": [8], "eval_envs": 0}
        return {
            "npg": SweepSpec(
                task="cartpole", algo="npg", overrides={**small, "value_batch_size": 16},
                grid={"kl_delta": [0.01, 0.05], "gae_lambda": [0.9, 0.97]}, seeds=(0, 1), iterations=iterations or 4,
            ),
            "ppo": SweepSpec(
                task="cartpole", algo="ppo", overrides={**small, "num_minibatches": 2, "num_epochs": 2},
                grid={"lr": [1e-3, 3e-4], "clip_eps": [0.1, 0.2]}, seeds=(0, 1), iterations=iterations or 4,
            ),
        }  # fmt: skip
    return {
        "npg": SweepSpec(
            task="hopper",
            algo="npg",
            preset="hopper_1m",
            grid={
                "kl_delta": [float(v) for v in np.geomspace(0.02, 0.2, 8)],
                "gae_lambda": [float(v) for v in np.linspace(0.9, 0.99, 8)],
            },
            seeds=(0, 1, 2, 3),
            iterations=iterations,
        ),
        "ppo": SweepSpec(
            task="ant",
            algo="ppo",
            preset="ant_1m",
            grid={
                "lr": [float(v) for v in np.geomspace(1e-4, 1e-3, 8)],
                "clip_eps": [float(v) for v in np.linspace(0.1, 0.3, 8)],
            },
            seeds=(0, 1, 2, 3),
            iterations=iterations,
        ),
    }


def peak_memory() -> dict[str, Any]:
    """The device allocator's peak bytes (largest over local devices), or the process's peak
    resident bytes on the CPU."""
    import jax

    device = jax.local_devices()[0]
    if device.platform != "cpu":
        peaks = [int((d.memory_stats() or {}).get("peak_bytes_in_use", 0)) for d in jax.local_devices()]
        return {"peak_bytes": max(peaks), "memory": f"{device.device_kind} allocator peak"}
    return {"peak_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, "memory": "host peak RSS"}


def run_single(spec: Any, index: int, seed: int) -> dict[str, Any]:
    """One run of configuration ``index`` with ``seed``, the static config as ``python -m jaxpg.cli``
    compiles it (no hparams), in blocks of iterations as the sweep; timings and peak memory."""
    import jax

    from jaxpg.envs import compile_options
    from jaxpg.sweep import runner

    start = time.perf_counter()
    env = spec.make_env()
    config = spec.expand(env)[index].config
    module = spec.module()
    iterations = spec.total_iterations()
    block = runner.iteration_block(iterations)
    init = compile_options.jit(lambda k: module.init(k, env, config), env)
    step = compile_options.jit(
        lambda ts: jax.lax.scan(lambda s, _: module.update(s), ts, None, length=block), env, donate_argnums=0
    )
    key = jax.random.PRNGKey(seed)
    compiled_init = init.lower(key).compile()
    state_spec = jax.eval_shape(init, key)
    compiled_step = step.lower(state_spec).compile()
    compile_s = time.perf_counter() - start
    train_start = time.perf_counter()
    state = compiled_init(key)
    returns = []
    for _ in range(iterations // block):
        state, metrics = compiled_step(state)
        returns.append(np.asarray(metrics["return_stochastic"]))
    train_s = time.perf_counter() - train_start
    return {"compile_s": compile_s, "train_s": train_s, "final_return": float(np.concatenate(returns)[-1]),
            **peak_memory()}  # fmt: skip


def sequential_sample(case: str, count: int, configs: int, args: argparse.Namespace) -> list[dict[str, Any]]:
    """``count`` runs (configurations spread evenly over the ``configs``, seed 0), each in a fresh
    process (``--single``), timed from its start."""
    indices = sorted({int(i) for i in np.linspace(0, configs - 1, count)})
    rows = []
    for index in indices:
        command = [sys.executable, __file__, "--single", case, "--config-index", str(index), "--out", str(args.out)]
        if args.quick:
            command.append("--quick")
        if args.iterations:
            command += ["--iterations", str(args.iterations)]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, check=False, env={**os.environ})
        wall = time.perf_counter() - start
        if done.returncode != 0:
            raise RuntimeError(f"sequential run {index} failed: {done.stderr[-2000:]}")
        row = json.loads(done.stdout.strip().splitlines()[-1])
        rows.append({"configuration": index, "seed": 0, "process_s": wall, **row})
        print(f"  sequential run of configuration {index}: {wall:.1f} s (training {row['train_s']:.1f} s)", flush=True)
    return rows


def run_case(case: str, spec: Any, args: argparse.Namespace) -> dict[str, Any]:
    """The sweep and its sequential sample (module docstring)."""
    from jaxpg.sweep import run_sweep

    out = Path(args.out) / f"{case}-sweep"
    if out.exists():
        import shutil

        shutil.rmtree(out)  # a timing, not a resume
    configs = len(spec.swept_values())
    runs = configs * len(spec.seeds)
    # The sequential sample first, while this process holds no device memory.
    print(f"{case}: {args.sequential} of the runs one process after another", flush=True)
    sample = sequential_sample(case, args.sequential, configs, args)
    print(f"{case}: {configs} configurations x {len(spec.seeds)} seeds = {runs} runs, one sweep", flush=True)
    start = time.perf_counter()
    report = run_sweep(spec, out, episodes=0, figures=False, runs_per_chunk=args.runs_per_chunk)
    sweep_s = time.perf_counter() - start
    sweep = {
        "runs": runs,
        "wall_s": sweep_s,
        "compile_s": report.timing["compile_s"],
        "train_s": report.timing["train_s"],
        **peak_memory(),
    }
    process_s = float(np.mean([r["process_s"] for r in sample]))
    train_s = float(np.mean([r["train_s"] for r in sample]))
    per_run_sweep = sweep_s / runs
    return {
        "case": case,
        "spec": spec.to_json(),
        "sweep": sweep,
        "sequential": sample,
        "sequential_process_s_per_run": process_s,
        "sequential_train_s_per_run": train_s,
        "sequential_extrapolated_s": process_s * runs,
        "sweep_s_per_run": per_run_sweep,
        "speedup": process_s / per_run_sweep,
        "speedup_training_only": train_s / (sweep["train_s"] / runs),
        "runs_per_hour_sweep": 3600.0 / per_run_sweep,
        "runs_per_hour_sequential": 3600.0 / process_s,
        "sequential_peak_bytes": max(r["peak_bytes"] for r in sample),
        "memory": sweep["memory"],
    }


def table(results: list[dict[str, Any]]) -> str:
    head = (
        f"{'case':<5} {'runs':>5} {'sweep s':>9} {'s/run':>8} {'seq s/run':>10} {'seq x runs':>11} "
        f"{'speed-up':>9} {'train-only':>10} {'runs/h sweep':>13} {'runs/h seq':>11} {'peak GiB':>9} {'seq GiB':>8}"
    )
    lines = [head]
    for r in results:
        lines.append(
            f"{r['case']:<5} {r['sweep']['runs']:>5} {r['sweep']['wall_s']:>9.1f} {r['sweep_s_per_run']:>8.2f} "
            f"{r['sequential_process_s_per_run']:>10.1f} {r['sequential_extrapolated_s']:>11.0f} "
            f"{r['speedup']:>8.1f}x {r['speedup_training_only']:>9.1f}x {r['runs_per_hour_sweep']:>13.0f} "
            f"{r['runs_per_hour_sequential']:>11.0f} {r['sweep']['peak_bytes'] / 2**30:>9.2f} "
            f"{r['sequential_peak_bytes'] / 2**30:>8.2f}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", required=True)
    p.add_argument("--case", choices=("npg", "ppo", "both"), default="both")
    p.add_argument("--quick", action="store_true", help="tiny sizes on cartpole (a CPU smoke test)")
    p.add_argument("--iterations", type=int, default=None, help="iterations of every run (default: the preset's)")
    p.add_argument("--sequential", type=int, default=2, help="runs of the sequential sample per case")
    p.add_argument("--runs-per-chunk", type=int, default=0, help="0: chosen from the device memory")
    p.add_argument("--single", default=None, help=argparse.SUPPRESS)
    p.add_argument("--config-index", type=int, default=0, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    from jaxpg.run.command import startup

    # Memory on demand, here and in the sequential processes (which inherit it): a process that
    # reserved 75 % of the GPU would leave the others too little, and the peaks stay comparable.
    startup.allocate_gpu_memory_on_demand()
    specs = cases(args.quick, args.iterations)
    if args.single:
        print(json.dumps(run_single(specs[args.single], args.config_index, 0)))
        return 0
    Path(args.out).mkdir(parents=True, exist_ok=True)
    import jax

    chosen = ["npg", "ppo"] if args.case == "both" else [args.case]
    results = [run_case(case, specs[case], args) for case in chosen]
    device = jax.local_devices()[0]
    print(f"device: {jax.local_device_count()} x {device.device_kind}; JAX {jax.__version__}")
    print(table(results))
    path = Path(args.out) / "sweep_speed.json"
    payload = {"device": device.device_kind, "devices": jax.local_device_count(), "jax": jax.__version__,
               "results": results}  # fmt: skip
    path.write_text(json.dumps(payload, indent=1, default=lambda x: x.item() if hasattr(x, "item") else str(x)))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
