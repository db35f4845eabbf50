"""``card_command.py card``: the card's command per seed, cold and warm caches, then scored in Gymnasium."""

from __future__ import annotations

import argparse
import re
import shutil
import statistics
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import harness

from card_modes import CARD_COMMAND

RAW = argparse.RawDescriptionHelpFormatter

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
the driver compiles the PTX it is handed for the GPU and keeps the result there; what keeping it
saves: ``docs/benchmarks_archive.md``, "The card command");
``--warm`` runs again with the caches that a first run filled. A bare machine still has the
Python bytecode that ``pip install`` compiles; where MuJoCo, MJX or Warp was installed without it
(``--no-compile``), a first line says so, since each run (or the first, where Python may write
bytecode) then compiles their sources.

    python benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --json card.json
"""


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
