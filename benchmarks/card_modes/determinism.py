"""``card_command.py determinism``: one seed run several times per setting, and where two runs differ."""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import harness

from card_modes import ROOT

RAW = argparse.RawDescriptionHelpFormatter

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
