"""``time_to_return.py run``: wall-clock seconds to a target mean-policy return, one fresh process per seed."""

from __future__ import annotations

import argparse
import ast
import dataclasses
import json
import os
import subprocess
import sys
import time
from collections.abc import Sequence

import harness

RAW = argparse.RawDescriptionHelpFormatter
SCRIPT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "time_to_return.py")


RUN_DOC = """Wall-clock time for a policy to reach a target mean-policy return, compilation included.

Each seed runs in a fresh process (so every run pays its own JAX compilation; MuJoCo Warp's
kernel cache under ~/.cache/warp stays warm after the first run on a machine, which the table
marks). The clock starts before the env is built and stops at the first evaluation whose
deterministic (mean-policy) return over ``--eval-envs`` full episodes reaches ``--target``.
Evaluation time is inside the clock, as in Brax's own reports.

    python benchmarks/time_to_return.py run --task hopper --algo ppo --target 3000 --seeds 0 1 2 \
        --set num_envs=8192 horizon=32 --max-seconds 300
"""


def parse_overrides(items: list[str]) -> dict:
    """``["num_envs=4096", "policy_hidden=(64,64)"]`` -> dict with Python literals."""
    out = {}
    for item in items:
        name, _, text = item.partition("=")
        try:
            out[name] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            out[name] = text
    return out


def run_one(args: argparse.Namespace, seed: int) -> dict:
    """Train one seed until the target or the time limit; returns the result row."""
    start = time.perf_counter()
    import jax

    from jaxpg.run.host import compile_cache

    cache = None if args.no_compilation_cache else compile_cache.enable()
    from jaxpg.envs import mjx_import

    if mjx_import.runs_jax_only(args.impl, jax.default_backend()):
        mjx_import.leave_out_warp()  # as jaxpg's command line does: MJX without MuJoCo Warp

    from jaxpg import algos, envs
    from jaxpg import train as train_lib
    from jaxpg.algos import core

    module = algos.get(args.algo)
    overrides = dict(module.PRESETS.get(args.preset, {})) if args.preset else {}
    overrides.update(parse_overrides(args.set))
    # No evaluation inside the training program (a cond around it would still be compiled into
    # it, and would run at iteration 0): the evaluation below runs per block, with eval_envs.
    overrides.update(eval_envs=0)
    config = module.Config(**overrides)
    env = envs.make(args.task, batch=config.num_envs, impl=args.impl, fidelity=args.fidelity)
    ts = module.init(jax.random.PRNGKey(seed), env, config)
    eval_config = dataclasses.replace(config, eval_envs=args.eval_envs)
    evaluate = jax.jit(lambda ts, key: core.evaluate(ts.replace(config=eval_config), key))
    per_call = args.iterations_per_call or args.block
    block_fn = train_lib.compiled_block(module.update, per_call, False)

    def block(ts):  # noqa: ANN001, ANN202
        for _ in range(args.block // per_call):
            ts, metrics = block_fn(ts)
        return ts, metrics

    ts = train_lib.own_buffers(ts)
    history = []
    reached_at = None
    while True:
        ts, metrics = block(ts)
        summary = evaluate(ts, jax.random.PRNGKey(10_000 + len(history)))
        ret = float(summary["episode_return"])
        elapsed = time.perf_counter() - start
        steps = int(ts.iteration) * config.samples_per_iteration
        stochastic = float(metrics["return_stochastic"][-1])
        history.append(
            {"seconds": elapsed, "env_steps": steps, "return_mean_policy": ret, "return_stochastic": stochastic}
        )
        print(
            f"  seed {seed}: {elapsed:7.1f} s  {steps / 1e6:8.2f} M steps  eval {ret:8.1f}  stoch {stochastic:8.1f}",
            flush=True,
        )
        if ret >= args.target and reached_at is None:
            reached_at = history[-1]
            break
        if elapsed > args.max_seconds:
            break
    best = max(h["return_mean_policy"] for h in history)
    return {
        "seed": seed,
        "reached": reached_at is not None,
        "seconds": reached_at["seconds"] if reached_at else None,
        "env_steps": reached_at["env_steps"] if reached_at else history[-1]["env_steps"],
        "best_return": best,
        "first_block_s": history[0]["seconds"],
        "impl": env.unwrapped.impl,
        "compilation_cache": str(cache) if cache else None,
        "device": jax.devices()[0].device_kind,
        "config": {k: v for k, v in overrides.items()},
        "eval_envs": args.eval_envs,
        "history": history,
    }


def run_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="time_to_return.py run", description=RUN_DOC, formatter_class=RAW)
    parser.add_argument("--task", default="hopper")
    parser.add_argument("--algo", default="npg")
    parser.add_argument("--preset", default=None)
    parser.add_argument("--impl", default=None)
    parser.add_argument("--fidelity", default="fast")
    parser.add_argument("--target", type=float, default=3000.0)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--set", nargs="*", default=[], help="Config overrides, name=value")
    parser.add_argument("--block", type=int, default=10, help="iterations between evaluations")
    parser.add_argument("--iterations-per-call", type=int, default=0, help="scan length (default: --block)")
    parser.add_argument("--eval-envs", type=int, default=32)
    parser.add_argument("--max-seconds", type=float, default=300.0)
    parser.add_argument("--json", help="write the rows here")
    parser.add_argument(
        "--no-compilation-cache", action="store_true", help="compile every program in every run (a cold start)"
    )
    parser.add_argument(
        "--warmup",
        action="store_true",
        help="first run one block of a throw-away seed, so that the timed runs find the compilation caches warm",
    )
    parser.add_argument("--single", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.single is not None:
        print("ROW " + json.dumps(run_one(args, args.single)), flush=True)
        return

    rows = []
    cold = None
    if args.warmup:
        cmd = [sys.executable, SCRIPT, "run", "--single", "1000"] + strip_seeds(list(argv)) + ["--max-seconds", "0"]
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, text=True, env=os.environ.copy())
        found = [json.loads(line[4:]) for line in proc.stdout.splitlines() if line.startswith("ROW ")]
        cold = found[0]["first_block_s"] if found else None
        print(f"# warm-up (seed 1000, one block, caches as found): first block {cold} s", flush=True)
    for seed in args.seeds:
        cmd = [sys.executable, SCRIPT, "run", "--single", str(seed)] + strip_seeds(list(argv))
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, text=True, env=os.environ.copy())
        found = [line for line in proc.stdout.splitlines() if line.startswith("ROW ")]
        for line in proc.stdout.splitlines():
            if not line.startswith("ROW "):
                print(line, flush=True)
        if not found:
            print(f"# seed {seed} failed (exit {proc.returncode})", flush=True)
            continue
        rows.append(json.loads(found[0][4:]))
    harness.write_json(args.json, [{**row, "warmup_first_block_s": cold} for row in rows], argv=list(argv))
    where = f"{rows[0]['device']} impl {rows[0]['impl']}" if rows else ""
    print(f"\n{args.task} {args.algo} target {args.target}; {where}")
    print("| seed | reached | wall clock s (incl. compile) | env steps | best mean-policy return | first block s |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        secs = f"{r['seconds']:.1f}" if r["reached"] else f"> {r['history'][-1]['seconds']:.0f}"
        print(
            f"| {r['seed']} | {r['reached']} | {secs} | {r['env_steps'] / 1e6:.1f} M | {r['best_return']:.0f} "
            f"| {r['first_block_s']:.1f} |"
        )
    times = sorted(r["seconds"] for r in rows if r["reached"])
    if len(times) == len(rows) and rows:
        print(f"median wall clock to {args.target}: {times[len(times) // 2]:.1f} s")


def strip_seeds(argv: list[str]) -> list[str]:
    """``argv`` without ``--seeds`` and its values."""
    out, skipping = [], False
    for a in argv:
        if a == "--seeds":
            skipping = True
            continue
        if skipping and not a.startswith("--"):
            continue
        skipping = False
        out.append(a)
    return out
