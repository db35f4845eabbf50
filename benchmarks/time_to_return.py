"""Time to a score: how long training takes to reach a return, and how settings change it.

Three modes (``python benchmarks/time_to_return.py MODE --help`` for each):

  run    wall-clock seconds for a policy to reach a target mean-policy return, compilation and
         evaluation included, one fresh process per seed;
  sweep  sample efficiency of named NPG settings on Hopper at the command line's batch (256
         envs), several seeds trained together, mean-policy returns at marks of env steps;
  plot   mean-policy return against wall clock from ``run --json`` files.

    python benchmarks/time_to_return.py run --task hopper --algo ppo --preset hopper_gpu --target 3000 \
        --seeds 0 1 2 --json ppo.json
    python benchmarks/time_to_return.py sweep --settings card card_s10 --seeds 0 1 2 3 4 5 6 7 --steps 1.97e6
    python benchmarks/time_to_return.py plot --out docs/hopper_time_to_return.png PPO=ppo.json NPG=npg.json
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import json
import math
import os
import subprocess
import sys
import time
from collections.abc import Sequence
from typing import Any

import harness

RAW = argparse.RawDescriptionHelpFormatter

RUN_DOC = """Wall-clock time for a policy to reach a target mean-policy return, compilation included.

Each seed runs in a fresh process (so every run pays its own JAX compilation; MuJoCo Warp's
kernel cache under ~/.cache/warp stays warm after the first run on a machine, which the table
marks). The clock starts before the env is built and stops at the first evaluation whose
deterministic (mean-policy) return over ``--eval-envs`` full episodes reaches ``--target``.
Evaluation time is inside the clock, as in Brax's own reports.

    python benchmarks/time_to_return.py run --task hopper --algo ppo --target 3000 --seeds 0 1 2 \
        --set num_envs=8192 horizon=32 --max-seconds 300
"""

SWEEP_DOC = """Sample efficiency of NPG settings on Hopper at the command line's batch (256 envs).

Each named setting trains several seeds together (``vmap``) for ``--steps`` env steps, and the
mean (deterministic) policy of every seed is evaluated on ``--eval-envs`` fresh episodes at each
mark of ``--marks`` (millions of env steps) by a separately jitted evaluation, outside the training
program. Prints one row per setting: the mean-policy return of each seed at each mark, the
training time after compilation and the compilation time.

    python benchmarks/time_to_return.py sweep --settings base step07 h32 --seeds 0 1 2 --steps 2e6 \
        --marks 1 1.5 2 --json sweep.json
"""

PLOT_DOC = """Plot mean-policy return against wall-clock seconds from ``time_to_return.py run --json`` files.

    python benchmarks/time_to_return.py plot --out docs/hopper_time_to_return.png \
        PPO=benchmarks/results/2026-11-22-h100/ppo.json,benchmarks/results/2026-11-22-h100/ppo12.json \
        NPG=benchmarks/results/2026-11-22-h100/npg.json,benchmarks/results/2026-11-22-h100/npg12.json
"""


# ========================================================================================== run


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
        cmd = [sys.executable, __file__, "run", "--single", "1000"] + strip_seeds(list(argv)) + ["--max-seconds", "0"]
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, text=True, env=os.environ.copy())
        found = [json.loads(line[4:]) for line in proc.stdout.splitlines() if line.startswith("ROW ")]
        cold = found[0]["first_block_s"] if found else None
        print(f"# warm-up (seed 1000, one block, caches as found): first block {cold} s", flush=True)
    for seed in args.seeds:
        cmd = [sys.executable, __file__, "run", "--single", str(seed)] + strip_seeds(list(argv))
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


# ========================================================================================== sweep

# The starting point: 256 envs x 64 steps, normalised step 0.05, observation normalisation,
# initial log-std -0.5, value 128x128 fitted for 3 epochs in minibatches of 1024.
BASE: dict[str, Any] = dict(
    num_envs=256,
    horizon=64,
    kl_delta=0.05,
    normalize_observations=True,
    log_std_init=-0.5,
    value_hidden=(128, 128),
    value_epochs=3,
    value_batch_size=1024,
    eval_envs=0,
)

SETTINGS: dict[str, dict[str, Any]] = {
    "base": {},
    "step07": dict(kl_delta=0.07),
    "step10": dict(kl_delta=0.1),
    "h32": dict(horizon=32),
    "h32s035": dict(horizon=32, kl_delta=0.035),
    "h32s07": dict(horizon=32, kl_delta=0.07),
    "vep10": dict(value_epochs=10),
    "vep10lr3": dict(value_epochs=10, value_lr=3e-3),
    "g99": dict(gamma=0.99, gae_lambda=0.95),
    "g99l97": dict(gamma=0.99),
    "std1": dict(log_std_init=-1.0),
    "pol32": dict(policy_hidden=(32, 32)),
    "damp01": dict(cg_damping=0.1),
    "step07vep10": dict(kl_delta=0.07, value_epochs=10),
    "h32vep10": dict(horizon=32, value_epochs=10),
    "vb256": dict(value_batch_size=256),
    "cg20": dict(cg_iters=20),
    "s07g99": dict(kl_delta=0.07, gamma=0.99, gae_lambda=0.95),
    "s07std1": dict(kl_delta=0.07, log_std_init=-1.0),
    "s10vep10": dict(kl_delta=0.1, value_epochs=10),
    "s07vep10lr3": dict(kl_delta=0.07, value_epochs=10, value_lr=3e-3),
    # Around the command line's default (step 0.07, 10 value epochs):
    "vnorm": dict(kl_delta=0.07, value_epochs=10, normalize_value_targets=True),
    "std0": dict(kl_delta=0.07, value_epochs=10, log_std_init=0.0),
    "vnorm_std0": dict(kl_delta=0.07, value_epochs=10, normalize_value_targets=True, log_std_init=0.0),
    "lam95": dict(kl_delta=0.07, value_epochs=10, gae_lambda=0.95),
    "vnorm_s10": dict(kl_delta=0.1, value_epochs=10, normalize_value_targets=True),
    "vnorm_vep5": dict(kl_delta=0.07, value_epochs=5, normalize_value_targets=True),
    "vep20": dict(kl_delta=0.07, value_epochs=20),
}

# Settings named card* start from the command line's own preset (npg's ``hopper``) instead of BASE,
# to look for what takes every seed past 3000 within 1 M env steps (the card's stretch aim).
CARD_SETTINGS: dict[str, dict[str, Any]] = {
    "card": {},
    "card_s085": dict(kl_delta=0.085),
    "card_s10": dict(kl_delta=0.1),
    "card_h48": dict(horizon=48),
    "card_lam97": dict(gae_lambda=0.97),
    "card_g995": dict(gamma=0.995),
    "card_vep15": dict(value_epochs=15),
}
SETTINGS.update(CARD_SETTINGS)


def base_config(name: str) -> dict[str, Any]:
    """The overrides a setting starts from: the card preset (evaluation off) for ``card*``, else BASE."""
    if name in CARD_SETTINGS:
        from jaxpg.algos import npg

        return {**npg.PRESETS["hopper"], "eval_envs": 0}
    return BASE


def run_setting(
    name: str,
    overrides: dict[str, Any],
    seeds: list[int],
    steps: float,
    marks: list[float],
    eval_envs: int,
    impl: str | None,
    block: int,
) -> dict[str, Any]:
    """Train one setting for every seed at once; returns its row."""
    import jax
    import numpy as np

    from jaxpg import envs, train
    from jaxpg.algos import core, npg

    config = npg.Config(**{**base_config(name), **overrides})
    batch = max(config.num_envs, eval_envs) * len(seeds)
    env = envs.make("hopper", batch=batch, impl=impl)
    eval_config = dataclasses.replace(config, eval_envs=eval_envs)

    @jax.jit
    def evaluate(ts: Any, key: jax.Array) -> Any:
        keys = jax.random.split(key, len(seeds))
        return jax.vmap(lambda t, k: core.evaluate(t.replace(config=eval_config), k))(ts, keys)

    start = time.perf_counter()
    ts = train.init_seeds(npg.init, seeds, env, config)
    iterations = math.ceil(steps / config.samples_per_iteration)
    mark_iters = sorted(
        {min(iterations, max(block, round(m * 1e6 / config.samples_per_iteration / block) * block)) for m in marks}
        | {iterations}
    )
    step_fn = train.compiled_block(npg.update, block, True)
    done, train_s, compile_s, returns = 0, 0.0, 0.0, {}
    ts = jax.tree.map(lambda x: x.copy(), ts)
    while done < iterations:
        n = min(block, iterations - done)
        fn = step_fn if n == block else train.compiled_block(npg.update, n, True)
        t0 = time.perf_counter()
        ts, metrics = fn(ts)
        jax.block_until_ready(ts)
        dt = time.perf_counter() - t0
        if done == 0:
            compile_s = dt
        else:
            train_s += dt
        done += n
        if done in mark_iters:
            out = jax.device_get(evaluate(ts, jax.random.PRNGKey(1000 + done)))
            returns[done * config.samples_per_iteration] = [float(x) for x in np.asarray(out["episode_return"])]
            stoch = np.nanmean(np.asarray(metrics["return_stochastic"])[-1])
            print(
                f"  {name} {done * config.samples_per_iteration / 1e6:.2f} M steps: mean policy "
                f"{' / '.join(f'{r:.0f}' for r in returns[done * config.samples_per_iteration])}, "
                f"stochastic {stoch:.0f}",
                flush=True,
            )
    total = time.perf_counter() - start
    return {
        "name": name,
        "overrides": {k: list(v) if isinstance(v, tuple) else v for k, v in overrides.items()},
        "seeds": seeds,
        "iterations": iterations,
        "returns": {str(k): v for k, v in returns.items()},
        "train_s": train_s,
        "first_block_s": compile_s,
        "total_s": total,
        "steps_per_s": (iterations - block) * config.samples_per_iteration * len(seeds) / max(train_s, 1e-9),
        "impl": env.impl,
        "device": jax.devices()[0].device_kind,
    }


def sweep_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="time_to_return.py sweep", description=SWEEP_DOC, formatter_class=RAW)
    parser.add_argument("--settings", nargs="+", default=["base"], choices=sorted(SETTINGS))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--steps", type=float, default=2e6, help="env steps per seed")
    parser.add_argument("--marks", nargs="+", type=float, default=[1.0, 1.5, 2.0], help="evaluate at (M steps)")
    parser.add_argument("--eval-envs", type=int, default=16)
    parser.add_argument("--impl", choices=("jax", "warp"), default=None)
    parser.add_argument("--block", type=int, default=8, help="iterations per compiled call (lax.scan)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)

    from jaxpg.run.host import compile_cache

    compile_cache.enable()
    rows = []
    for name in args.settings:
        row = run_setting(
            name, SETTINGS[name], args.seeds, args.steps, args.marks, args.eval_envs, args.impl, args.block
        )
        rows.append(row)
        harness.write_json(args.json, rows, argv=list(argv))
    marks = " | ".join(f"@ {int(k) / 1e6:.2f} M" for k in rows[0]["returns"])
    print(f"\n| setting | overrides | {marks} | train s | first block s | env steps/s |")
    print("|---" * (5 + len(rows[0]["returns"])) + "|")
    for row in rows:
        cells = []
        for values in row["returns"].values():
            cells.append(f"{min(values):.0f} / {sum(values) / len(values):.0f}")
        print(
            f"| {row['name']} | {row['overrides']} | {' | '.join(cells)} | {row['train_s']:.1f} | "
            f"{row['first_block_s']:.1f} | {row['steps_per_s'] / 1e3:.0f} k |"
        )
    print("cells: min / mean over seeds of the mean-policy return")


# ========================================================================================== plot


def plot_main(argv: Sequence[str]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    parser = argparse.ArgumentParser(prog="time_to_return.py plot", description=PLOT_DOC, formatter_class=RAW)
    parser.add_argument("series", nargs="+", help="LABEL=file.json[,file.json...]")
    parser.add_argument("--out", required=True)
    parser.add_argument("--title", default="Hopper, one H100 (MuJoCo Warp): mean-policy return vs wall clock")
    args = parser.parse_args(argv)
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, spec in enumerate(args.series):
        label, _, files = spec.partition("=")
        rows = [row for f in files.split(",") for row in harness.rows_of(f)]
        for j, row in enumerate(rows):
            seconds = [h["seconds"] for h in row["history"]]
            returns = [h["return_mean_policy"] for h in row["history"]]
            ax.plot(seconds, returns, color=f"C{i}", alpha=0.8, label=label if j == 0 else None)
    ax.axhline(3000, color="gray", linestyle="--", linewidth=1)
    ax.set_xlabel("wall clock, seconds (compilation included)")
    ax.set_ylabel("mean-policy return (32 episodes)")
    ax.set_title(args.title, fontsize=10)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)


MODES = {"run": run_main, "sweep": sweep_main, "plot": plot_main}


if __name__ == "__main__":
    harness.run_modes(__file__, MODES, __doc__)
