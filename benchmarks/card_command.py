"""The command jaxpg is known by, ``python experiments/hopper.py --num-envs 256``, run as a user
runs it: each run a fresh process, timed as a whole.

Seven modes (``python benchmarks/card_command.py MODE --help`` for each):

  card         time the command per seed with empty caches (cold) and with caches a first run
               filled (warm), then score each run's policy in Gymnasium's CPU Hopper-v5;
  determinism  run the same seed several times per setting (MuJoCo Warp, XLA's deterministic
               ops, MJX's JAX implementation) and find where two runs' metrics first differ;
  kernels      time MuJoCo Warp's kernel build for the card's Hopper on a bare machine, serial
               at first execution against all host cores while XLA compiles;
  capture      step MuJoCo Warp's physics with and without an XLA compilation on another
               thread: does Warp's CUDA-graph capture survive it?
  startup      in fresh processes, JAX's backend start and `import mujoco.mjx` one after the
               other, and the import on a thread while the backend starts: does overlapping help?
               With --sample: the card's command itself, its main thread's stack sampled every
               50 ms up to the `training:` line, summed by what jaxpg was doing.
  memory       in fresh processes, JAX's GPU backend start and its first buffers, with JAX's
               default (75 % of the GPU's memory reserved at the first buffer) and with memory
               taken on demand (XLA_PYTHON_CLIENT_PREALLOCATE=false, what jaxpg's commands set).
  parts        the card's command inside this process, with JAX's tracing, lowering and compilation
               (or cache load) of each program, and the Python time of MuJoCo Warp's FFI callbacks.

    python benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --json card.json
    python benchmarks/card_command.py determinism --settings default deterministic jax --runs 3
    python benchmarks/card_command.py kernels --builds serial parallel
    python benchmarks/card_command.py capture --seconds 60
    python benchmarks/card_command.py startup --repeats 3
    python benchmarks/card_command.py startup --sample 2 --extra --preset hopper_1m
    python benchmarks/card_command.py memory --repeats 3
    python benchmarks/card_command.py parts --json parts.json
"""

from __future__ import annotations

import argparse
import atexit
import json
import logging
import math
import os
import re
import runpy
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import harness

RAW = argparse.RawDescriptionHelpFormatter
CARD_COMMAND = ("experiments/hopper.py", "--num-envs", "256")  # from the repository root
ROOT = Path(__file__).resolve().parent.parent
CARD_DOC = """The command jaxpg is known by, timed as a user runs it, then judged in Gymnasium.

For each seed this runs, as a separate process, exactly

    python experiments/hopper.py --num-envs 256 --seed S --run-dir RUN

(no other flag), timing the whole process (imports, MuJoCo Warp kernels, XLA compilation,
training, evaluations, checkpoints), then

    python -m jaxpg.evaluate RUN --gymnasium --episodes 10

and prints, per seed: wall clock, env steps, the last in-run mean-policy return and the mean
return in Gymnasium's CPU Hopper-v5, then where each run's time went, from the arrival times of
its output lines and the seconds the run reports (``SPLIT``: start-up, the first block's XLA
compilation, the wait for MuJoCo Warp's kernels after it, the rest of the first block, the other
iterations, the evaluations, exit; ``python benchmarks/card_command.py kernels`` times the
kernel build alone), and the start-up's own parts from the run's ``start-up:`` line
(``STARTUP_PARTS``: imports, the env, the initial state, the run directory).

``--cold`` gives every run empty caches, as on a bare machine: its own XLA
compilation cache, MuJoCo Warp kernel cache and CUDA driver compute cache (``CUDA_CACHE_PATH``:
the driver compiles the PTX it is handed for the GPU and keeps the result there; 34 MB after one
run on an H100, and with it kept a run with the other two caches empty took 26-35 s less);
``--warm`` runs again with the caches that a first run filled. A bare machine still has the
Python bytecode that ``pip install`` compiles; where MuJoCo, MJX or Warp was installed without it
(``--no-compile``), a first line says so, since each run (or the first, where Python may write
bytecode) then compiles their sources.

    python benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --json card.json
"""

DETERMINISM_DOC = """Does one seed give the same numbers in two processes? Which part of a GPU run breaks it?

For each setting this runs the same training command several times, each run a fresh process,
and compares the runs' ``metrics.jsonl`` field by field, iteration by iteration (wall-clock
fields left out). Within a setting the first run starts with empty caches (it compiles and
autotunes, as on a fresh machine) and the later runs load its compiled programs from the
persistent compilation cache, so:

* ``warm vs warm`` differing means the same compiled program gives different numbers from run to
  run (non-deterministic kernels, e.g. atomic additions in reductions or in MuJoCo Warp);
* ``cold vs warm`` differing while ``warm vs warm`` agrees means compiling again changes the
  numbers (e.g. XLA's autotuner choosing other GPU kernels).

Settings (``--settings``): ``default`` (MuJoCo Warp when installed), ``deterministic``
(``XLA_FLAGS=--xla_gpu_deterministic_ops=true``), ``jax`` (``--impl jax``: MJX's JAX
implementation instead of Warp). The command is ``python experiments/hopper.py --num-envs 256
--iterations N`` with ``--seed S``.

    python benchmarks/card_command.py determinism --settings default deterministic jax --runs 3 --iterations 20
"""


# ========================================================================================== card


def train_once(seed: int, run_dir: Path, caches: Path, log: Path, extra: list[str]) -> dict[str, Any]:
    """One training process, timed as a whole; returns the row without the Gymnasium score."""
    env = {
        "JAXPG_COMPILATION_CACHE": str(caches / "xla"),
        "WARP_CACHE_PATH": str(caches / "warp"),
        "CUDA_CACHE_PATH": str(caches / "cuda"),  # the driver's cache of the PTX it compiled
    }
    command = [sys.executable, *CARD_COMMAND, "--seed", str(seed)]
    status, wall, stamped = harness.run_process([*command, "--run-dir", str(run_dir), *extra], env, log)
    rows = harness.metrics_rows(run_dir)
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
        "split_s": split(stamped, wall),
        "startup_s": startup_parts(stamped),
        "log_tail": log.read_text().splitlines()[-6:],
    }


SPLIT = {
    "startup": "imports, planning, the initial state, to the `training:` line",
    "xla_compile": "XLA's compilation of the first block, or its loading from the cache (the `first block:` line)",
    "kernel_wait": "then waiting for MuJoCo Warp's kernels, built beside the compilation",
    "first_block": "the rest of the first block: setting up checkpoints, running its iterations",
    "training": "the other iterations, to the `done in` line, without the evaluations",
    "evaluation": "the mean-policy evaluations (the `evaluation:` line)",
    "exit": "the closing report, checkpoints' last writes and the process's exit",
}


def split(stamped: list[tuple[float, str]], wall: float) -> dict[str, float | None]:
    """Seconds of each part of ``SPLIT``: from the arrival times of the run's output lines (the
    `training:` line, the first progress line, the `done in` line, the process's end) and the
    seconds the run reports (the `first block:` and `evaluation:` lines). ``None`` for a part whose
    line never came; a run that reports no compilation or evaluation counts 0 for them."""

    def first(pattern: str) -> float | None:
        return next((t for t, line in stamped if re.match(pattern, line)), None)

    def seconds(pattern: str) -> float:
        match = next((m for _, line in stamped if (m := re.search(pattern, line))), None)
        return float(match.group(1)) if match else 0.0

    compile_s = seconds(r"^first block: compiled in ([\d.]+) s")
    wait_s = seconds(r"^first block: .*, then ([\d.]+) s waiting")
    eval_s = seconds(r"^evaluation: .*?, ([\d.]+) s \(")
    start, first_line, done = (
        first(r"(training|resuming at iteration \d+): "),
        first(r"\[\s*\d+/\d+\]"),
        first(r"done in "),
    )

    def span(a: float | None, b: float | None, minus: float = 0.0) -> float | None:
        return b - a - minus if a is not None and b is not None else None

    whole_first = span(start, first_line)
    return {
        "startup": start,
        "xla_compile": compile_s if whole_first is not None else None,
        "kernel_wait": wait_s if whole_first is not None else None,
        "first_block": span(start, first_line, compile_s + wait_s),
        "training": span(first_line, done, eval_s),
        "evaluation": eval_s if done is not None else None,
        "exit": span(done, wall),
    }


STARTUP_PARTS = {
    "imports": "before planning (Python, jax, jaxpg, JAX's backend) and mujoco.mjx with MuJoCo Warp",
    "env": "planning and building the env, without the MJX import",
    "initial_state": "the initial training state",
    "run_dir": "the run directory and the rest, to the first block",
}


def startup_parts(stamped: list[tuple[float, str]]) -> dict[str, float] | None:
    """``STARTUP_PARTS`` from the run's ``start-up:`` line (``None`` without one, or without the
    process's seconds before planning)."""
    line = next((line for _, line in stamped if line.startswith("start-up: ")), None)
    pattern = (
        r"start-up: [\d.]+ s to the first block: ([\d.]+) s before planning"
        r"(?: \(([\d.]+) s of it importing mujoco\.mjx\))?, ([\d.]+) s planning and building the env"
        r"(?: \(([\d.]+) s of it importing mujoco\.mjx\))?, ([\d.]+) s the initial state, ([\d.]+) s the run"
    )
    match = re.match(pattern, line or "")
    if match is None:
        return None
    before, _, planning, mjx_in_planning, state, rest = (float(x) if x else 0.0 for x in match.groups())
    return {
        "imports": before + mjx_in_planning,
        "env": planning - mjx_in_planning,
        "initial_state": state,
        "run_dir": rest,
    }


def collect(pending: list, wait: bool) -> None:
    """Fill in the Gymnasium scores of the evaluations that have finished (all, with ``wait``)."""
    for row, gym_log, process in pending:
        if "gymnasium_return" in row or (not wait and process.poll() is None):
            continue
        process.wait()
        row["gymnasium_return"], row["gymnasium_std"] = harness.gymnasium_score(gym_log)
        row["gymnasium_output"] = gym_log.read_text().splitlines()[-3:]
        print(f"  {row['mode']} seed {row['seed']}: Gymnasium {row['gymnasium_return']} ± {row['gymnasium_std']}")


def card_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="card_command.py card", description=CARD_DOC, formatter_class=RAW)
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--modes", nargs="+", choices=("cold", "warm"), default=["cold", "warm"])
    parser.add_argument("--out", default=None, help="where runs and logs go (default: a temporary directory)")
    parser.add_argument("--json", default=None)
    parser.add_argument("--extra", nargs=argparse.REMAINDER, default=[], help="extra flags (not the card's command)")
    args = parser.parse_args(argv)

    out = Path(args.out or tempfile.mkdtemp(prefix="card-"))
    out.mkdir(parents=True, exist_ok=True)
    if (note := harness.bytecode_note(harness.bytecode())) is not None:
        print(note, flush=True)
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
            pending.append((row, gym_log, harness.gymnasium_replay(run_dir, gym_log)))
            print(
                f"  {mode} seed {seed}: {row['wall_s']:.1f} s, {row['env_steps']:,.0f} env steps, in-run mean "
                f"policy {row['in_run_mean_policy']}, exit {row['status']}",
                flush=True,
            )
            if mode == "cold" and "warm" in args.modes and not shared_caches.exists():
                shutil.copytree(caches, shared_caches)  # the warm runs start from a first run's caches
            collect(pending, wait=False)
            harness.write_json(args.json, rows, argv=list(argv))
    collect(pending, wait=True)
    harness.write_json(args.json, rows, argv=list(argv))
    print("\n| mode | seed | wall clock s | env steps | evaluations (s) | in-run mean policy | Gymnasium Hopper-v5 |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        print(
            f"| {row['mode']} | {row['seed']} | {row['wall_s']:.1f} | {row['env_steps']:,.0f} | "
            f"{row['evaluations']} ({row['eval_s']:.1f}) | {row['in_run_mean_policy'] or float('nan'):.0f} | "
            f"{row['gymnasium_return'] or float('nan'):.0f} ± {row['gymnasium_std'] or float('nan'):.0f} |"
        )
    print("\nwhere the time went (s): " + "; ".join(f"{part}: {what}" for part, what in SPLIT.items()))
    print("| mode | seed | " + " | ".join(SPLIT) + " |")
    print("|---|---|" + "---|" * len(SPLIT))
    for row in rows:
        cells = [row["split_s"][part] for part in SPLIT]
        print(
            f"| {row['mode']} | {row['seed']} | " + " | ".join("-" if c is None else f"{c:.1f}" for c in cells) + " |"
        )
    print("\nthe start-up (s): " + "; ".join(f"{part}: {what}" for part, what in STARTUP_PARTS.items()))
    print("| mode | seed | " + " | ".join(STARTUP_PARTS) + " |")
    print("|---|---|" + "---|" * len(STARTUP_PARTS))
    for row in rows:
        parts = row["startup_s"] or {}
        cells = ["-" if part not in parts else f"{parts[part]:.1f}" for part in STARTUP_PARTS]
        print(f"| {row['mode']} | {row['seed']} | " + " | ".join(cells) + " |")
    for mode in args.modes:
        walls = [r["wall_s"] for r in rows if r["mode"] == mode]
        gyms = [r["gymnasium_return"] or float("nan") for r in rows if r["mode"] == mode]
        print(f"{mode}: median wall clock {statistics.median(walls):.1f} s, Gymnasium min {min(gyms):.0f}")


# ========================================================================================== determinism

SETTINGS: dict[str, tuple[dict[str, str], list[str]]] = {
    "default": ({}, []),
    "deterministic": ({"XLA_FLAGS": "--xla_gpu_deterministic_ops=true"}, []),
    "jax": ({}, ["--impl", "jax"]),
}
TIMING_FIELDS = ("wall_time_s", "eval_seconds")


def run_once(
    run_dir: Path, caches: Path, env_vars: dict[str, str], flags: list[str], args: argparse.Namespace
) -> float:
    """One training process with its own run directory and the setting's caches; its wall clock."""
    env = {
        **os.environ,
        **env_vars,
        "JAXPG_COMPILATION_CACHE": str(caches / "xla"),
        "WARP_CACHE_PATH": str(caches / "warp"),
        "CUDA_CACHE_PATH": str(caches / "cuda"),  # the driver's cache of the PTX it compiled
        "PYTHONUNBUFFERED": "1",
    }
    command = [sys.executable, "experiments/hopper.py", "--num-envs", str(args.num_envs), "--seed", str(args.seed)]
    command += ["--iterations", str(args.iterations), "--run-dir", str(run_dir), "--no-progress", *flags]
    start = time.perf_counter()
    with (run_dir.parent / f"{run_dir.name}.log").open("w") as log:
        status = subprocess.run(command, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT).returncode
    if status != 0:
        raise SystemExit(f"error: {' '.join(command)} exited with {status}; see {run_dir.parent / run_dir.name}.log")
    return time.perf_counter() - start


def read_metrics(run_dir: Path) -> list[dict[str, Any]]:
    """The run's ``metrics.jsonl`` rows."""
    return [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines() if line.strip()]


def compare(a: list[dict[str, Any]], b: list[dict[str, Any]]) -> dict[str, Any]:
    """Where two runs' metrics first differ: ``{"identical", "first_iteration", "field", "max_rel"}``
    (``max_rel``: the largest relative difference of any numeric field at any iteration where both
    values are finite; a NaN or infinity against another value is a difference without a size)."""
    first: tuple[int, str] | None = None
    max_rel = 0.0
    for row_a, row_b in zip(a, b, strict=True):
        for field in sorted(set(row_a) | set(row_b)):
            if field in TIMING_FIELDS:
                continue
            x, y = row_a.get(field), row_b.get(field)
            if x == y or (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y)):
                continue
            if first is None:
                first = (int(row_a.get("iteration", -1)), field)
            if isinstance(x, int | float) and isinstance(y, int | float) and math.isfinite(x) and math.isfinite(y):
                max_rel = max(max_rel, abs(x - y) / max(abs(x), abs(y), 1e-12))
    return {
        "identical": first is None,
        "first_iteration": None if first is None else first[0],
        "field": None if first is None else first[1],
        "max_rel": max_rel,
    }


def determinism_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(
        prog="card_command.py determinism", description=DETERMINISM_DOC, formatter_class=RAW
    )
    parser.add_argument("--settings", nargs="+", choices=tuple(SETTINGS), default=list(SETTINGS))
    parser.add_argument("--runs", type=int, default=3, help="runs per setting (the first with empty caches)")
    parser.add_argument("--iterations", type=int, default=20)
    parser.add_argument("--num-envs", type=int, default=256)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None, help="where runs and logs go (default: a temporary directory)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    if args.runs < 2:
        parser.error("--runs must be >= 2 (one cold run and at least one warm run to compare with it)")
    out = Path(args.out or tempfile.mkdtemp(prefix="determinism-"))
    out.mkdir(parents=True, exist_ok=True)

    rows = []
    for setting in args.settings:
        env_vars, flags = SETTINGS[setting]
        caches = out / setting / "caches"
        caches.mkdir(parents=True, exist_ok=True)
        metrics, walls = [], []
        for i in range(args.runs):
            run_dir = out / setting / f"run{i}"
            walls.append(run_once(run_dir, caches, env_vars, flags, args))
            metrics.append(read_metrics(run_dir))
            print(f"  {setting} run {i}: {walls[-1]:.1f} s, {len(metrics[-1])} iterations", flush=True)
        pairs = [("cold vs warm", 0, 1)] + [("warm vs warm", 1, j) for j in range(2, args.runs)]
        for name, i, j in pairs:
            result = compare(metrics[i], metrics[j])
            where = "identical" if result["identical"] else f"first differs at iteration {result['first_iteration']}"
            print(f"  {setting}, {name}: {where}, largest relative difference {result['max_rel']:.2e}", flush=True)
            rows.append({"setting": setting, "pair": name, "runs": [i, j], "wall_s": walls, **result})

    print(f"\nhopper, {args.num_envs} envs, seed {args.seed}, {args.iterations} iterations per run")
    print("| setting | pair | identical | first differing iteration (field) | largest relative difference |")
    print("|---|---|---|---|---|")
    for r in rows:
        where = "-" if r["identical"] else f"{r['first_iteration']} ({r['field']})"
        print(f"| {r['setting']} | {r['pair']} | {'yes' if r['identical'] else 'no'} | {where} | {r['max_rel']:.2e} |")
    harness.write_json(args.json, rows, argv=list(argv))


# ====================================================================================== kernels

KERNELS_DOC = """How long MuJoCo Warp's kernels for the card's Hopper take to build on a bare machine, one
after another at the first execution (as MJX builds them) or on all host cores while XLA
compiles (``jaxpg.envs.warp_kernels.KernelBuild``, what the command line does).

Each build runs in a fresh process with empty Warp, CUDA driver and XLA caches: 256 envs of the
card's Hopper stepped once (``AutoReset``, fidelity "fast", MuJoCo Warp), timing the XLA
compilation, the wait for the background build and the first execution (which builds whatever
is not built yet).

    python benchmarks/card_command.py kernels --builds serial parallel --json kernels.json
"""


def kernels_child(build: str) -> dict[str, Any]:
    """One build in this process: seconds of imports, XLA compilation, wait and first step."""
    start = time.perf_counter()
    import jax
    import jax.numpy as jnp

    from jaxpg import envs
    from jaxpg.envs.warp_kernels import KernelBuild

    row: dict[str, Any] = {"build": build, "import_s": time.perf_counter() - start}
    env = envs.AutoReset(envs.make("hopper", impl="warp", batch=256))
    states = jax.block_until_ready(jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), 256)))
    actions = jnp.zeros((256, env.action_size))
    t = time.perf_counter()
    kernels = KernelBuild.start(env) if build == "parallel" else None
    step = jax.jit(jax.vmap(env.step))
    step.lower(states, actions).compile()
    row["xla_compile_s"] = time.perf_counter() - t
    t = time.perf_counter()
    if kernels is not None:
        kernels.wait()
        row.update(
            modules=kernels.modules, build_s=kernels.seconds, error=repr(kernels.error) if kernels.error else None
        )
    row["wait_s"] = time.perf_counter() - t
    t = time.perf_counter()
    jax.block_until_ready(step(states, actions))
    row["first_step_s"] = time.perf_counter() - t
    row["total_s"] = time.perf_counter() - start
    return row


def kernels_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="card_command.py kernels", description=KERNELS_DOC, formatter_class=RAW)
    parser.add_argument("--builds", nargs="+", choices=("serial", "parallel"), default=["serial", "parallel"])
    parser.add_argument("--child", choices=("serial", "parallel"), help=argparse.SUPPRESS)
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    if args.child:
        print("ROW " + json.dumps(kernels_child(args.child)), flush=True)
        return
    rows = []
    for build in args.builds:
        with tempfile.TemporaryDirectory() as caches:
            env = {
                **os.environ,
                "WARP_CACHE_PATH": f"{caches}/warp",
                "CUDA_CACHE_PATH": f"{caches}/cuda",
                "JAX_COMPILATION_CACHE_DIR": "",
            }
            out = subprocess.run(
                [sys.executable, __file__, "kernels", "--child", build], env=env, capture_output=True, text=True
            )
        lines = [line for line in out.stdout.splitlines() if line.startswith("ROW ")]
        if not lines:
            raise SystemExit(f"the {build} build failed:\n{out.stderr[-3000:]}")
        rows.append(json.loads(lines[-1][4:]))
        print(f"  {build}: {rows[-1]}", flush=True)
    print(f"\n{harness.describe()}")
    print("| build | imports s | XLA compile s | waiting for the build s | first step s | whole process s |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        cells = [r["import_s"], r["xla_compile_s"], r["wait_s"], r["first_step_s"], r["total_s"]]
        print(f"| {r['build']} | " + " | ".join(f"{x:.1f}" for x in cells) + " |")
    harness.write_json(args.json, rows, argv=list(argv))


# ============================================================================================= capture

CAPTURE_DOC = """Does an XLA compilation on another thread break MuJoCo Warp's CUDA-graph capture?

MJX runs a MuJoCo Warp physics step as an XLA FFI call, and Warp captures the step into a CUDA
graph the first time it sees a call's buffers. This steps 256 Walker2d envs (a jitted scan of 8
env steps per call; the last 200 outputs are kept alive, so later calls get new buffers and Warp
captures again) for ``--seconds``, first alone, then with a thread compiling XLA programs beside
it, and prints whether the stepping survived.

On one H200 (2026-11-27) stepping with a compiling thread failed after 74 calls (3 s) with
``Warp CUDA error 904: capturing stream has unjoined work``; alone, 899 calls in 30 s passed.
Training runs sharing a GPU failed the same way (CUDA error 901) while their evaluation program
compiled on a background thread; ``jaxpg.train.train`` now compiles nothing while a MuJoCo Warp
program runs. Needs a GPU: on the CPU Warp captures no graphs.

    python benchmarks/card_command.py capture --seconds 60 --json capture.json
"""
CAPTURE_ENVS = 256


def keep_compiling(stop: Any, count: list[int]) -> None:
    """Compile a new small XLA program (a matrix product of a new size) until ``stop`` is set."""
    import jax
    import jax.numpy as jnp

    size = 256
    while not stop.is_set():
        program = jax.jit(lambda a, b: jnp.tanh(a @ b) @ b.T + jnp.sort(a, axis=0))
        spec = jax.ShapeDtypeStruct((size, size), jnp.float32)
        program.lower(spec, spec).compile()
        count[0] += 1
        size += 8


def step_for(seconds: float, compile_beside: bool) -> dict[str, Any]:
    """Step the envs for ``seconds``, with or without a compiling thread: calls, compilations,
    seconds and the error that stopped the stepping (``None``: none)."""
    import threading

    import jax

    from jaxpg import envs

    env = envs.make("walker2d", impl="warp", batch=CAPTURE_ENVS)

    def body(states: Any, key: jax.Array) -> tuple[Any, None]:
        actions = jax.random.uniform(key, (CAPTURE_ENVS, env.action_size), minval=-1.0, maxval=1.0)
        return jax.vmap(env.step)(states, actions), None

    roll = jax.jit(lambda states, key: jax.lax.scan(body, states, jax.random.split(key, 8))[0])
    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), CAPTURE_ENVS))
    states = jax.block_until_ready(roll(states, jax.random.key(0)))  # compiled and captured once
    stop, count = threading.Event(), [0]
    compiler = threading.Thread(target=keep_compiling, args=(stop, count), daemon=True)
    if compile_beside:
        compiler.start()
    kept: list[Any] = []
    calls, error, start = 0, None, time.perf_counter()
    try:
        while time.perf_counter() - start < seconds:
            states = jax.block_until_ready(roll(states, jax.random.key(calls + 1)))
            kept = [*kept[-200:], states]  # alive: the next calls get new buffers, captured anew
            calls += 1
    except Exception as e:  # noqa: BLE001 - the error is the measurement
        error = str(e).splitlines()[0][:200]
    stop.set()
    if compile_beside:
        compiler.join()  # exiting during a compilation aborts the process
    return {
        "compiling_thread": compile_beside,
        "calls": calls,
        "compilations": count[0],
        "seconds": time.perf_counter() - start,
        "error": error,
    }


def capture_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="card_command.py capture", description=CAPTURE_DOC, formatter_class=RAW)
    parser.add_argument("--seconds", type=float, default=60.0, help="stepping time of each setting (default: 60)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    rows = [step_for(args.seconds, False), step_for(args.seconds, True)]
    harness.write_json(args.json, rows, argv=list(argv))
    print(f"\n{harness.describe()}")
    print(
        harness.table(
            rows,
            [
                ("compiling thread", lambda r: "yes" if r["compiling_thread"] else "no"),
                ("calls", lambda r: r["calls"]),
                ("compilations", lambda r: r["compilations"]),
                ("seconds", lambda r: f"{r['seconds']:.0f}"),
                ("error", lambda r: r["error"] or "none"),
            ],
        )
    )


# ========================================================================================== startup

# Each snippet runs in a fresh process and prints its seconds as JSON: ``import jax``, JAX's
# backend start (``jax.devices()``) and ``import mujoco.mjx`` (MuJoCo Warp's modules included),
# in turn or with the import on a thread while the backend starts; then jaxpg's import of MJX
# (``jaxpg.envs.mjx_import``, jaxpg's own import counted in the total only), with MuJoCo Warp and
# with it left out (``JAXPG_MJX_WARP=off``, what a command that steps on JAX only does); "trimesh
# imported": trimesh imported first, as MJX did before jaxpg deferred it (``mjx_import.DeferredModule``).
STARTUP_SNIPPETS = {
    "in turn": """
import json, time
t0 = time.perf_counter(); import jax
t1 = time.perf_counter(); jax.devices()
t2 = time.perf_counter(); import mujoco.mjx
t3 = time.perf_counter()
print(json.dumps({"import jax": t1 - t0, "backend": t2 - t1, "import mjx": t3 - t2, "total": t3 - t0}))
""",
    "import on a thread": """
import json, threading, time
t0 = time.perf_counter(); import jax
t1 = time.perf_counter()
thread = threading.Thread(target=__import__, args=("mujoco.mjx",)); thread.start(); jax.devices()
t2 = time.perf_counter(); thread.join()
t3 = time.perf_counter()
print(json.dumps({"import jax": t1 - t0, "backend": t2 - t1, "import mjx": t3 - t2, "total": t3 - t0}))
""",
}

# jaxpg's import of MJX: ``{warp}`` sets ``JAXPG_MJX_WARP`` or nothing, ``{first}`` imports trimesh
# inside the timed import or nothing.
JAXPG_IMPORT_SNIPPET = """
import json, os, time
{warp}
t0 = time.perf_counter(); import jax
t1 = time.perf_counter(); jax.devices()
from jaxpg.envs import mjx_import
t2 = time.perf_counter(); {first}mjx_import.import_mjx()
t3 = time.perf_counter()
print(json.dumps({{"import jax": t1 - t0, "backend": t2 - t1, "import mjx": t3 - t2, "total": t3 - t0}}))
"""
STARTUP_SNIPPETS |= {
    f"jaxpg, {name}{trimesh}": JAXPG_IMPORT_SNIPPET.format(warp=warp, first=first)
    for name, warp in (("with Warp", ""), ("Warp left out", 'os.environ["JAXPG_MJX_WARP"] = "off"'))
    for trimesh, first in (("", ""), (", trimesh imported", "import trimesh; "))
}


# Runs the card's command (its flags after the first two arguments) while a thread writes the main
# thread's stack, innermost frame first, every 50 ms to the file named by the first argument.
SAMPLER = r"""
import os, runpy, sys, threading, time, traceback
path, main_thread, start = sys.argv[1], threading.get_ident(), time.perf_counter()
seconds = float(sys.argv[2])
def sample():
    with open(path, "w") as out:
        while time.perf_counter() - start < seconds:
            frame = sys._current_frames().get(main_thread)
            if frame is not None:
                stack = [f"{f.filename}:{f.name}" for f in traceback.extract_stack(frame)[::-1]]
                out.write(f"{time.perf_counter() - start:.2f}\t" + ";".join(stack[:60]) + "\n")
                out.flush()  # the run ends with os._exit, which flushes nothing
            time.sleep(0.05)
threading.Thread(target=sample, daemon=True).start()
sys.argv = ["experiments/hopper.py", *sys.argv[3:]]
runpy.run_path("experiments/hopper.py", run_name="__main__")
"""


def sampled_activity(stack: str) -> str:
    """What one sample's main thread was doing: ``import`` while a module is being imported, else
    its innermost jaxpg frame (``file.py:function``), else its innermost frame."""
    frames = stack.split(";")
    if any("_find_and_load" in frame for frame in frames):
        return "import"
    ours = [frame for frame in frames if "/jaxpg/" in frame]
    return (ours[0] if ours else frames[0]).rsplit("/", 1)[-1]


def sample_card(out: Path, extra: list[str], runs: int) -> list[dict[str, Any]]:
    """A first run that fills the caches, then ``runs`` sampled warm runs of the card's command:
    per run, the seconds to the `training:` line and the seconds each activity took before it."""
    env = {
        "JAXPG_COMPILATION_CACHE": str(out / "caches" / "xla"),
        "WARP_CACHE_PATH": str(out / "caches" / "warp"),
        "CUDA_CACHE_PATH": str(out / "caches" / "cuda"),
    }
    card = ["--num-envs", "256", "--no-progress", *extra]
    fill = [sys.executable, "experiments/hopper.py", *card, "--run-dir", str(out / "fill")]
    harness.run_process(fill, env, out / "fill.log")
    rows = []
    for run in range(runs):
        samples = out / f"samples{run}.txt"
        command = [sys.executable, "-c", SAMPLER, str(samples), "30", *card, "--run-dir", str(out / f"sampled{run}")]
        _, wall, stamped = harness.run_process(command, env, out / f"sampled{run}.log")
        training = next((t for t, line in stamped if line.startswith("training: ")), wall)
        activity: dict[str, float] = {}
        taken = [(float(t), stack) for t, stack in (line.split("\t", 1) for line in samples.read_text().splitlines())]
        for (seconds, stack), (following, _) in zip(taken, [*taken[1:], (training, "")], strict=True):
            if seconds < training:  # each sample stands for the time until the next one
                name = sampled_activity(stack)
                activity[name] = activity.get(name, 0.0) + min(following, training) - seconds
        rows.append({"run": run, "to_training_s": training, "wall_s": wall, "activity_s": activity})
    return rows


def startup_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(
        prog="card_command.py startup",
        description="Fresh-process start-up: JAX's backend and `import mujoco.mjx`, in turn or overlapped "
        "(`import mjx` is then what is left of the import after the backend started), and jaxpg's import of "
        "MJX with MuJoCo Warp and without (`backend` then includes importing jaxpg).",
    )
    parser.add_argument("--repeats", type=int, default=3, help="processes per order, alternating (default: 3)")
    parser.add_argument("--sample", type=int, default=0, help="instead: this many sampled warm runs of the card")
    parser.add_argument("--out", default=None, help="--sample's runs and samples (default: a temporary directory)")
    parser.add_argument("--json", default=None)
    parser.add_argument("--extra", nargs=argparse.REMAINDER, default=[], help="--sample: flags added to the card's")
    args = parser.parse_args(argv)
    if args.sample:
        out = Path(args.out or tempfile.mkdtemp(prefix="card-sample-"))
        out.mkdir(parents=True, exist_ok=True)
        sampled = sample_card(out, args.extra, args.sample)
        harness.write_json(args.json, sampled, argv=list(argv))
        print(f"\n{harness.describe()}")
        for row in sampled:
            seconds_to, wall = row["to_training_s"], row["wall_s"]
            print(f"run {row['run']}: `training:` after {seconds_to:.2f} s, whole process {wall:.1f} s")
            for name, seconds in sorted(row["activity_s"].items(), key=lambda kv: -kv[1])[:12]:
                print(f"  {seconds:5.2f} s  {name}")
        print("(a sample every 50 ms or more, an import may delay one; each counts until the next)")
        return
    rows = []
    for repeat in range(args.repeats):
        for order, code in STARTUP_SNIPPETS.items():
            done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
            if done.returncode != 0:
                raise SystemExit(f"error: the {order} snippet failed: {done.stderr.strip().splitlines()[-1:]}")
            rows.append({"order": order, "repeat": repeat, **json.loads(done.stdout.strip().splitlines()[-1])})
    harness.write_json(args.json, rows, argv=list(argv))
    print(f"\n{harness.describe()}")
    parts = ("import jax", "backend", "import mjx", "total")
    print(harness.table(rows, [("order", lambda r: r["order"])] + [(p, lambda r, p=p: f"{r[p]:.2f}") for p in parts]))
    for order in STARTUP_SNIPPETS:
        totals = [r["total"] for r in rows if r["order"] == order]
        print(f"{order}: median {statistics.median(totals):.2f} s over {len(totals)} processes")


# ========================================================================================== memory

# A fresh process's GPU start, in seconds (JSON): ``import jax``, the backend (``jax.devices()``),
# the first buffer (where JAX's client reserves its memory pool unless told not to), 500 more small
# buffers, ``import mujoco.mjx`` (MuJoCo Warp's modules included) and MJX's Warp ``put_model`` of
# the card's Hopper, twice.
MEMORY_SNIPPET = """
import json, sys, time
import numpy as np
t0 = time.perf_counter(); import jax, jax.numpy as jnp
t1 = time.perf_counter(); jax.devices()
t2 = time.perf_counter(); jnp.zeros(1).block_until_ready()
t3 = time.perf_counter(); jax.block_until_ready(jax.device_put([np.ones(3, np.float32) for _ in range(500)]))
t4 = time.perf_counter(); import mujoco; from mujoco import mjx
t5 = time.perf_counter(); model = mujoco.MjModel.from_xml_path(sys.argv[1])
jax.block_until_ready(mjx.put_model(model, impl="warp"))
t6 = time.perf_counter(); jax.block_until_ready(mjx.put_model(model, impl="warp"))
t7 = time.perf_counter()
print(json.dumps({"import jax": t1 - t0, "backend": t2 - t1, "first buffer": t3 - t2, "500 buffers": t4 - t3,
                  "import mjx": t5 - t4, "put_model": t6 - t5, "put_model again": t7 - t6}))
"""
MEMORY_PARTS = ("import jax", "backend", "first buffer", "500 buffers", "import mjx", "put_model", "put_model again")
MEMORY_SETTINGS = {"JAX's default (preallocate)": "true", "on demand (jaxpg's)": "false"}


def memory_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(
        prog="card_command.py memory",
        description="Fresh-process GPU start with JAX's memory reserved at the first buffer (its default) and "
        "taken on demand (XLA_PYTHON_CLIENT_PREALLOCATE=false), alternating; the card's Hopper put on the GPU "
        "by MJX's Warp put_model. A GPU and MuJoCo Warp are needed. For the whole card both ways: "
        "XLA_PYTHON_CLIENT_PREALLOCATE=true python benchmarks/card_command.py card ... (a value you set is kept).",
    )
    parser.add_argument("--repeats", type=int, default=3, help="processes per setting, alternating (default: 3)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    xml = str(ROOT / "jaxpg" / "envs" / "assets" / "hopper.xml")
    rows = []
    for repeat in range(args.repeats):
        for setting, value in MEMORY_SETTINGS.items():
            env = {**os.environ, "XLA_PYTHON_CLIENT_PREALLOCATE": value}
            done = subprocess.run(
                [sys.executable, "-c", MEMORY_SNIPPET, xml], cwd=ROOT, env=env, capture_output=True, text=True
            )
            if done.returncode != 0:
                raise SystemExit(f"error: the {setting} process failed: {done.stderr.strip().splitlines()[-1:]}")
            rows.append({"setting": setting, "repeat": repeat, **json.loads(done.stdout.strip().splitlines()[-1])})
    harness.write_json(args.json, rows, argv=list(argv))
    print(f"\n{harness.describe()}")
    columns = [(part, lambda r, part=part: f"{r[part]:.2f}") for part in MEMORY_PARTS]
    print(harness.table(rows, [("memory", lambda r: r["setting"])] + columns))
    for setting in MEMORY_SETTINGS:
        first = [r["first buffer"] for r in rows if r["setting"] == setting]
        print(f"{setting}: first buffer median {statistics.median(first):.2f} s over {len(first)} processes")


PARTS_DOC = """The card's command, ``python experiments/hopper.py --num-envs 256``, run inside this process with
two clocks that a whole-process timing (``card_command.py card``) cannot see:

- **JAX's work on each program before it runs**, from JAX's own compile log (``jax_log_compiles``):
  tracing, lowering to MLIR, and XLA's compilation or its load from the persistent cache (a cache
  hit is named). A warm run's "programs loaded" (the first block's ``compiled in`` line) is these
  for the training block and the evaluation, which MuJoCo Warp's runs prepare on two threads
  before the first block: their times overlap, so the line is less than their sum;
- **the Python time of MuJoCo Warp's FFI callbacks**: MJX calls each of MuJoCo Warp's kernels
  through an XLA FFI target whose handler is a Python function (Warp's ``ffi_callback``), run
  under the GIL at every call; on a GPU it launches a captured CUDA graph, on a CPU it runs the
  kernels themselves. Each call is timed, counted by target, the first call of each target (a
  graph capture on a GPU) apart from the rest.

    python benchmarks/card_command.py parts --json parts.json          # the card, as typed
    python benchmarks/card_command.py parts -- --iterations 10 --impl warp   # on a CPU, shorter

Flags after ``--`` are added to the card's command. Run it after a first run filled the caches
(``JAXPG_COMPILATION_CACHE``, ``WARP_CACHE_PATH``) to see a warm run. The training's output is
printed as usual; the tables follow it.
"""
# JAX's compile log: "Finished tracing + transforming NAME for pjit in S sec" (wording varies by
# version), "Finished jaxpr to MLIR module conversion jit(NAME) in S sec", "Finished XLA
# compilation of jit(NAME) in S sec", and "Persistent compilation cache hit for 'jit_NAME'".
_STAGES = (
    ("tracing", re.compile(r"tracing")),
    ("lowering", re.compile(r"MLIR")),
    ("compile", re.compile(r"XLA compilation")),
)
_SECONDS = re.compile(r" in ([0-9.eE+-]+) sec")
_NAME = re.compile(r"jit\(([^)]*)\)|tracing(?: \+ transforming)? (\S+) for")
_CACHE_HIT = re.compile(r"[Pp]ersistent compilation cache hit for 'jit_([^']+)'")


class CompileLog(logging.Handler):
    """Collects JAX's compile-log lines: ``stages[name][stage]`` seconds (summed over repeats) and
    the names whose program came from the persistent cache."""

    def __init__(self) -> None:
        super().__init__(level=logging.DEBUG)
        self.stages: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
        self.cache_hits: set[str] = set()

    def emit(self, record: logging.LogRecord) -> None:
        parse_line(record.getMessage(), self.stages, self.cache_hits)


def parse_line(message: str, stages: dict[str, dict[str, float]], cache_hits: set[str]) -> None:
    """Add one compile-log line to ``stages`` (``name -> stage -> seconds``) or ``cache_hits``."""
    if (hit := _CACHE_HIT.search(message)) is not None:
        cache_hits.add(plain_name(hit.group(1)))
        return
    seconds, name = _SECONDS.search(message), _NAME.search(message)
    if not message.startswith("Finished") or seconds is None or name is None:
        return
    for stage, pattern in _STAGES:
        if pattern.search(message):
            stages[name.group(1) or name.group(2)][stage] += float(seconds.group(1))
            return


def plain_name(name: str) -> str:
    """A program's name as both log lines can be matched on: ``<lambda>`` and the cache's
    ``_lambda`` are both ``lambda``."""
    return re.sub(r"[^0-9A-Za-z_]", "", name).strip("_")


class CallbackClock:
    """Wraps FFI handlers ``handler(call_frame, platform)`` to time every call, by target name."""

    def __init__(self) -> None:
        self.calls: dict[str, list[float]] = defaultdict(list)

    def wrap(self, name: str, handler: Callable[..., Any]) -> Callable[..., Any]:
        """``handler`` with each call's seconds appended to ``calls[name]``; its result unchanged."""

        def timed(*args: Any) -> Any:
            start = time.perf_counter()
            try:
                return handler(*args)
            finally:
                self.calls[name].append(time.perf_counter() - start)

        return timed

    def summary(self) -> dict[str, Any]:
        """Calls, seconds in all, seconds of each target's first call (on a GPU: its graph capture)
        and the median microseconds of the later calls."""
        later = [s for seconds in self.calls.values() for s in seconds[1:]]
        return {
            "targets": len(self.calls),
            "calls": sum(len(s) for s in self.calls.values()),
            "seconds": sum(sum(s) for s in self.calls.values()),
            "first_calls_s": sum(s[0] for s in self.calls.values() if s),
            "later_calls_s": sum(later),
            "later_median_us": statistics.median(later) * 1e6 if later else None,
        }


def time_warp_callbacks(clock: CallbackClock) -> str | None:
    """Route every FFI target Warp registers from now on through ``clock``; a note if this Warp
    has no such hook (then its callbacks are not timed)."""
    try:
        from warp._src.jax import ffi
    except ImportError as e:
        return f"MuJoCo Warp's callbacks not timed: {e}"
    register = getattr(ffi, "_register_ffi_targets", None)
    if register is None:
        return "MuJoCo Warp's callbacks not timed: this Warp has no _register_ffi_targets"

    def register_timed(name: str, callback: Callable[..., Any]) -> Any:
        return register(name, clock.wrap(name, callback))

    ffi._register_ffi_targets = register_timed
    return None


def report(log: CompileLog, clock: CallbackClock, wall_s: float, note: str | None, json_path: str | None) -> None:
    """Print the two tables and write the JSON."""
    programs = sorted(log.stages, key=lambda n: -sum(log.stages[n].values()))
    rows = [
        {
            "program": n,
            **{s: log.stages[n].get(s, 0.0) for s, _ in _STAGES},
            "cache_hit": plain_name(n) in log.cache_hits,
        }
        for n in programs
    ]
    big = [r for r in rows if r["tracing"] + r["lowering"] + r["compile"] >= 0.05]
    small = [r for r in rows if r not in big]
    others = [{"program": f"{len(small)} others", **{s: sum(r[s] for r in small) for s, _ in _STAGES}}] if small else []
    print(f"\nJAX's work before each program runs (s), {harness.describe()}:")
    print(
        harness.table(
            big + others,
            [
                ("program", lambda r: r["program"]),
                ("tracing", lambda r: f"{r['tracing']:.2f}"),
                ("lowering", lambda r: f"{r['lowering']:.2f}"),
                ("compile or cache load", lambda r: f"{r['compile']:.2f}"),
                ("from the cache", lambda r: {True: "yes", False: "no"}.get(r.get("cache_hit"), "-")),
            ],
        )
    )
    summary = clock.summary()
    print(f"\nMuJoCo Warp's FFI callbacks (Python, under the GIL), whole process {wall_s:.1f} s:")
    if note is not None:
        print(note)
    else:
        median = summary["later_median_us"]
        print(
            harness.table(
                [summary],
                [
                    ("targets", lambda r: r["targets"]),
                    ("calls", lambda r: f"{r['calls']:,}"),
                    ("seconds in all", lambda r: f"{r['seconds']:.2f}"),
                    ("first call of each target (s)", lambda r: f"{r['first_calls_s']:.2f}"),
                    ("later calls (s)", lambda r: f"{r['later_calls_s']:.2f}"),
                    ("later calls, median us", lambda r: "-" if median is None else f"{median:.0f}"),
                ],
            )
        )
    harness.write_json(json_path, {"programs": rows, "warp_callbacks": summary, "wall_s": wall_s, "note": note})


def parts_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="card_command.py parts", description=PARTS_DOC, formatter_class=RAW)
    parser.add_argument("--json", default=None)
    parser.add_argument("--run-dir", default=None, help="the run's directory (default: a new temporary one)")
    parser.add_argument("extra", nargs="*", help="after --: flags added to the card's command")
    args = parser.parse_args(argv)

    clock, log = CallbackClock(), CompileLog()
    note = time_warp_callbacks(clock)  # before MJX registers its targets
    import jax

    jax.config.update("jax_log_compiles", True)
    jax_logger = logging.getLogger("jax")
    jax_logger.addHandler(log)
    jax_logger.propagate = False  # the log goes to the tables, not to the terminal
    start = time.perf_counter()
    atexit.register(lambda: report(log, clock, time.perf_counter() - start, note, args.json))
    run_dir = args.run_dir or tempfile.mkdtemp(prefix="card-parts-")
    sys.argv = [str(ROOT / CARD_COMMAND[0]), *CARD_COMMAND[1:], "--run-dir", run_dir, *args.extra]
    runpy.run_path(sys.argv[0], run_name="__main__")  # ends the process, after the atexit handlers


MODES = {
    "card": card_main,
    "determinism": determinism_main,
    "kernels": kernels_main,
    "capture": capture_main,
    "startup": startup_main,
    "memory": memory_main,
    "parts": parts_main,
}


if __name__ == "__main__":
    harness.run_modes(__file__, MODES, __doc__)
