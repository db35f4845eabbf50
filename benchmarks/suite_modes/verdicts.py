"""The suite's targets (published returns, fast presets' goals) and the verdict on a setting's seeds."""

from __future__ import annotations

import argparse
import math
import statistics
from collections.abc import Sequence
from typing import Any

# The best published on-policy return within 1 M env steps for each task, and its source
# (CPU simulators, Gymnasium v3/v4: compare with care): Tianshou's MuJoCo benchmark (best 10-seed
# average of NPG, TRPO, PPO and A2C).
SAMPLE_EFFICIENT_BEST: dict[str, tuple[float, str]] = {
    "hopper": (2609.0, "Tianshou PPO"),
    "walker2d": (3827.0, "Tianshou TRPO"),
    "half_cheetah": (5784.0, "Tianshou PPO"),
    "ant": (3485.0, "Tianshou A2C"),
    "humanoid": (1726.0, "Tianshou A2C"),
}
# What a fast preset is asked to reach, and within how many seconds of the whole process on one
# GPU with warm caches.
FAST_TARGETS: dict[str, tuple[float, float]] = {
    "walker2d": (4000.0, 300.0),
    "half_cheetah": (6000.0, 300.0),
    "ant": (4000.0, 300.0),
    "humanoid": (5000.0, 600.0),
}
# Tasks whose fast preset is asked to beat the best published return found, any algorithm and
# budget, and its source (CPU simulators, older Gymnasium versions: compare with care).
FAST_PUBLISHED_BEST: dict[str, tuple[float, str]] = {
    "swimmer": (365.7, "SB3 RL Zoo TRPO, Swimmer-v3, 1 M steps"),
    "reacher": (-2.6, "Tianshou SAC, Reacher-v2, 1 M steps"),
    "pusher": (-28.95, "CleanRL TD3 (JAX), Pusher-v2"),
}


def score_text(value: float) -> str:
    """A return as the tables print it: whole numbers from 100 up (``3346``), two decimals below,
    where the tasks' differences lie (Reacher's ``-3.48``, Pusher's ``-28.74``); ``nan`` as is."""
    return f"{value:.0f}" if abs(value) >= 100 else f"{value:.2f}"


def parse_run(text: str) -> tuple[str, str, str]:
    """``"walker2d:ppo:walker2d_fast"`` -> ``("walker2d", "ppo", "walker2d_fast")``."""
    parts = text.split(":")
    if len(parts) != 3 or not all(parts):
        raise argparse.ArgumentTypeError(f"expected TASK:ALGO:PRESET, got {text!r}")
    return parts[0], parts[1], parts[2]


def seeds_label(seeds: Sequence[int]) -> str:
    """A run directory's seed part: ``[3]`` -> ``"seed3"``, ``[0, 2, 5]`` -> ``"seed0-2-5"``, and a
    run of consecutive seeds as its ends, ``[0, 1, ..., 63]`` -> ``"seeds0to63"``, so that a block of
    many seeds stays within a file name's 255 bytes."""
    consecutive = len(seeds) > 2 and list(seeds) == list(range(seeds[0], seeds[0] + len(seeds)))
    return f"seeds{seeds[0]}to{seeds[-1]}" if consecutive else f"seed{'-'.join(map(str, seeds))}"


def judge(task: str, preset: str, scores: list[float], walls: list[float], steps: list[float]) -> str:
    """What the median Gymnasium score of a preset's seeds says against its target."""
    if not scores:
        return "no score"
    median = statistics.median(scores)
    if preset.endswith("_1m") and task in SAMPLE_EFFICIENT_BEST:
        best, source = SAMPLE_EFFICIENT_BEST[task]
        over_budget = max(steps) > 1_000_000
        verdict = "met" if median > best and not over_budget else f"missed by {best - median:.0f}"
        return f"{verdict} ({source} {best:.0f}{'; over 1 M steps' if over_budget else ''})"
    if preset.endswith("_fast") and task in FAST_TARGETS:
        target, seconds = FAST_TARGETS[task]
        late = statistics.median(walls) > seconds
        verdict = "met" if median >= target and not late else f"missed by {max(target - median, 0):.0f}"
        return f"{verdict} (>= {target:.0f} within {seconds:.0f} s{'; too slow' if late else ''})"
    if preset.endswith("_fast") and task in FAST_PUBLISHED_BEST:
        best, source = FAST_PUBLISHED_BEST[task]
        return f"{'met' if median > best else f'missed by {best - median:.2f}'} ({source} {best:g})"
    return "no target"


def finite_or_none(value: Any) -> Any:
    """``value`` with every float that is not finite (a run that never scored: NaN) as ``None``,
    nested in lists and dicts: JSON has no NaN, and a bare ``NaN`` breaks strict readers."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: finite_or_none(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [finite_or_none(v) for v in value]
    return value


def unknown_runs(runs: Sequence[tuple[str, str, str]]) -> list[str]:
    """One line for each ``TASK:ALGO:PRESET`` that ``jaxpg.cli`` would refuse (unknown task,
    algorithm, or a preset the algorithm lacks for that task): checked before any run starts."""
    from jaxpg import algos, envs

    problems = []
    for task, algo, preset in runs:
        run = f"{task}:{algo}:{preset}"
        if task not in envs.names():
            problems.append(f"{run}: unknown task {task!r}; known tasks: {', '.join(envs.names())}")
        elif algo not in algos.ALGORITHMS:
            problems.append(f"{run}: unknown algorithm {algo!r}; known: {', '.join(algos.ALGORITHMS)}")
        elif preset not in algos.preset_names(algo, task):
            known = ", ".join(algos.preset_names(algo, task)) or "none"
            problems.append(f"{run}: {algo} has no preset {preset!r} for {task}; its presets there: {known}")
    return problems


def is_finite(value: Any) -> bool:
    """A number that is finite (``metrics.jsonl`` writes a non-finite one as the text "nan")."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def failures(rows: Sequence[dict], episodes: int) -> list[str]:
    """One line for each run that failed: its process's exit status was not 0, or (with a
    Gymnasium replay) it has no score."""
    lines = []
    for row in rows:
        run = f"{row['task']}:{row['algo']}:{row['preset']} seed {row['seed']}"
        if row["status"] != 0:
            lines.append(f"{run}: exit status {row['status']} (its log is beside {row['run_dir']})")
        elif episodes > 0 and not is_finite(row.get("gymnasium_return")):
            lines.append(f"{run}: no Gymnasium score (its replay failed; the log is beside {row['run_dir']})")
    return lines


def summary(rows: list[dict]) -> list[dict]:
    """One row per TASK:ALGO:PRESET: its seeds' scores, medians and verdict."""
    groups: dict[tuple[str, str, str], list[dict]] = {}
    for row in rows:
        groups.setdefault((row["task"], row["algo"], row["preset"], row.get("caches", "")), []).append(row)
    out = []
    for (task, algo, preset, caches), runs in groups.items():
        scores = [r["gymnasium_return"] for r in runs if r.get("gymnasium_return") is not None]
        walls, steps = [r["wall_s"] for r in runs], [r["env_steps"] for r in runs]
        out.append(
            {
                "run": f"{task}:{algo}:{preset}" + (f" ({caches})" if caches else ""),
                "seeds": len(runs),
                "scores": scores,
                "in_run": [r["in_run_mean_policy"] for r in runs if r.get("in_run_mean_policy") is not None],
                "median": statistics.median(scores) if scores else math.nan,
                "wall_s": statistics.median(walls),
                "env_steps": statistics.median(steps),
                "verdict": judge(task, preset, scores, walls, steps),
            }
        )
    return out
