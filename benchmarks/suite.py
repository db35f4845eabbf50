"""The Gymnasium MuJoCo suite trained: tasks x presets x seeds, each a fresh process as a user runs
it, each final mean policy scored in Gymnasium's own v5 env, against the published figures.

Four modes (``python benchmarks/suite.py MODE --help`` for each):

  run   train every ``TASK:ALGO:PRESET`` for every seed, then replay each run's final mean policy
        in Gymnasium; print the table, write JSON (runs and their metrics);
  plot  mean-policy return against wall clock and against env steps, one panel per task, the
        seeds of each preset as a band, from ``run --json`` files;
  count how many seeds of each setting reached a score, over any number of ``run --json`` files
        (to judge a setting's failure rate over hundreds of seeds);
  physics replay each seed's policy of a run directory in Gymnasium's env under Gymnasium's
        physics and under jaxpg's fast fidelity: does a policy lose return to the physics change?

    python benchmarks/suite.py run --runs walker2d:npg:walker2d_1m half_cheetah:npg:half_cheetah_1m --seeds 0 1 2 \\
        --json suite.json
    python benchmarks/suite.py plot suite.json --out docs/suite.png
    python benchmarks/suite.py physics RUN_DIR --episodes 20 --json physics.json
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import os
import shutil
import statistics
import sys
import tempfile
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import harness

RAW = argparse.RawDescriptionHelpFormatter

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

RUN_DOC = """Train every TASK:ALGO:PRESET for every seed, each a fresh process, and score it in Gymnasium.

Each run is exactly ``python -m jaxpg.cli --env TASK --algo ALGO --preset PRESET --seed S
--run-dir DIR`` (plus ``--extra``), timed as a whole process (imports, compilation, training,
evaluations, checkpoints); its final mean policy is then replayed for ``--episodes`` episodes in
Gymnasium's own env (``python -m jaxpg.evaluate DIR --gymnasium``, on the CPU, beside the next
run). The caches (XLA, MuJoCo Warp, CUDA driver) are shared by all runs unless ``--cold`` gives
each run its own empty ones; ``--warmup`` fills them first, so that every timed run is warm;
``--bare-first`` first runs each TASK:ALGO:PRESET's first seed in full with empty caches of its
own (a "bare" row: the fresh-machine time), whose filled caches its timed runs then use; the runs
go preset by preset, so a session cut short keeps whole presets. On a host of several GPUs,
``--gpus 0 1 2 3`` runs a process on each GPU at a time, side by side (a free GPU takes the next
bare run while a preset's warm runs wait for theirs). The JSON is written after every run (with
``"partial": true`` and the Gymnasium scores of the replays that have ended), and in full at the
end. A preset whose name ends in ``_1m`` is judged as sample-efficient (at most 1 M env steps,
against the best published figure); one ending in ``_fast`` against the fast target and its time
limit (Swimmer, Reacher, Pusher: the best published return found).

    python benchmarks/suite.py run --runs hopper:npg:hopper walker2d:npg:walker2d_1m --seeds 0 1 2
    python benchmarks/suite.py run --runs walker2d:ppo:walker2d_fast humanoid:ppo:humanoid_fast \\
        --seeds 0 1 2 --bare-first --gpus 0 1 2 3
"""

PLOT_DOC = """Mean-policy return against wall clock and against env steps, one column per task.

Reads ``run --json`` files; each TASK:ALGO:PRESET is a line (the median over seeds) in a band (the
lowest to the highest seed), on a common grid of wall-clock seconds and of env steps.

    python benchmarks/suite.py plot suite.json --out docs/suite.png
    python benchmarks/suite.py count blocks/*.json --bar 3000
"""

COUNT_DOC = """How many seeds of each setting reached a Gymnasium score, over ``run --json`` files.

A setting is a TASK:ALGO:PRESET with the ``--extra`` flags its runs were given; a seed that two
files both hold is counted once (the later file's). Prints one row per setting: seeds, how many
scored at or above ``--bar``, the share below it, the lowest and the median, and the seeds below.

    python benchmarks/suite.py count results/*.json --bar 3000
"""


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


def _finite(value: Any) -> bool:
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
        elif episodes > 0 and not _finite(row.get("gymnasium_return")):
            lines.append(f"{run}: no Gymnasium score (its replay failed; the log is beside {row['run_dir']})")
    return lines


def train_and_time(
    task: str,
    algo: str,
    preset: str,
    seeds: list[int],
    out: Path,
    caches: Path,
    extra: list[str],
    gpu: int | None = None,
) -> list[dict]:
    """One run as a fresh process, training ``seeds`` (several: together in one vmapped program),
    on GPU number ``gpu`` alone when given (``CUDA_VISIBLE_DEVICES``); one row per seed (without
    the Gymnasium score)."""
    name = f"{task}-{algo}-{preset}-{seeds_label(seeds)}"
    run_dir = out / name
    shutil.rmtree(run_dir, ignore_errors=True)
    env = {
        "JAXPG_COMPILATION_CACHE": str(caches / "xla"),
        "WARP_CACHE_PATH": str(caches / "warp"),
        "CUDA_CACHE_PATH": str(caches / "cuda"),
        **({} if gpu is None else {"CUDA_VISIBLE_DEVICES": str(gpu)}),
    }
    command = [sys.executable, "-m", "jaxpg.cli", "--env", task, "--algo", algo, "--preset", preset]
    command += ["--seeds" if len(seeds) > 1 else "--seed", *map(str, seeds), "--run-dir", str(run_dir), *extra]
    status, wall, _ = harness.run_process(command, env, out / f"{name}.log")
    metrics = harness.metrics_rows(run_dir)
    out_rows = []
    for seed in seeds:
        rows = [r for r in metrics if r.get("seed", seed) == seed]
        evaluated = [r for r in rows if _finite(r.get("return_mean_policy"))]
        curve = [(r["wall_time_s"], r["env_steps"], r["return_mean_policy"]) for r in evaluated]
        out_rows.append(
            {
                "task": task,
                "algo": algo,
                "preset": preset,
                "seed": seed,
                "seeds_in_process": len(seeds),
                "status": status,
                "wall_s": wall,
                "env_steps": rows[-1]["env_steps"] if rows else math.nan,
                "in_run_mean_policy": evaluated[-1]["return_mean_policy"] if evaluated else None,
                "curve": curve,  # (training wall clock s, env steps, mean-policy return) at each evaluation
                "run_dir": str(run_dir),
                "extra": extra,
            }
        )
    return out_rows


def on_gpus(
    jobs: Sequence,
    gpus: Sequence[int | None],
    work: Callable[[object, int | None], None],
    ready: Callable[[object], bool] = lambda job: True,
) -> None:
    """``work(job, gpu)`` for every job, one job at a time per entry of ``gpus`` (each GPU runs
    one process at a time, the GPUs side by side). A free GPU takes the first job in order that is
    ``ready`` (checked again whenever a job ends; a job that is not ready waits, e.g. for the run
    that fills its caches); an exception in a job is raised once all have ended."""
    queue, errors = list(jobs), []
    changed = threading.Condition()

    def worker(gpu: int | None) -> None:
        while True:
            with changed:
                while queue and not any(ready(job) for job in queue):
                    changed.wait()
                if not queue:
                    return
                job = queue.pop(next(i for i, job in enumerate(queue) if ready(job)))
            try:
                work(job, gpu)
            except Exception as error:  # noqa: BLE001 - re-raised below, after the other jobs
                errors.append(error)
            finally:
                with changed:
                    changed.notify_all()

    threads = [threading.Thread(target=worker, args=(gpu,)) for gpu in gpus]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    if errors:
        raise errors[0]


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


def run_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="suite.py run", description=RUN_DOC, formatter_class=RAW)
    parser.add_argument("--runs", nargs="+", type=parse_run, required=True, help="TASK:ALGO:PRESET ...")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument(
        "--episodes", type=int, default=10, help="Gymnasium episodes per run; 0: no replay (default: 10)"
    )
    parser.add_argument("--cold", action="store_true", help="every run with its own empty caches")
    parser.add_argument(
        "--vmap-seeds",
        action="store_true",
        help="train each TASK:ALGO:PRESET's seeds together in one process (one vmapped program: to compare "
        "settings over many seeds; its wall clock is the whole batch's, not one seed's)",
    )
    parser.add_argument(
        "--gpus",
        nargs="+",
        type=int,
        default=None,
        help="run processes side by side, one on each of these GPUs at a time (CUDA_VISIBLE_DEVICES); "
        "default: one process at a time on every GPU",
    )
    parser.add_argument(
        "--warmup",
        action="store_true",
        help="first run each TASK:ALGO:PRESET for a few seconds of training (compiling the programs and "
        "kernels the timed runs use), so that every timed run finds warm caches",
    )
    parser.add_argument(
        "--bare-first",
        action="store_true",
        help="run each TASK:ALGO:PRESET's first seed with empty caches of its own (reported apart, as "
        "'bare'), then every seed with the caches it filled (as 'warm'), preset by preset",
    )
    parser.add_argument("--out", default=None, help="where runs and logs go (default: a temporary directory)")
    parser.add_argument("--json", default=None)
    parser.add_argument("--extra", nargs=argparse.REMAINDER, default=[], help="flags added to every run")
    args = parser.parse_args(argv)
    if sum((args.cold, args.warmup, args.bare_first)) > 1:
        parser.error("--cold, --warmup and --bare-first each set the runs' caches: choose one")
    if args.bare_first and args.vmap_seeds:
        parser.error("--bare-first times single seeds: it does not combine with --vmap-seeds")
    unknown = unknown_runs(args.runs)
    if unknown:
        for line in unknown:
            print(f"error: {line}", file=sys.stderr)
        raise SystemExit(2)

    out = Path(args.out or tempfile.mkdtemp(prefix="suite-"))
    out.mkdir(parents=True, exist_ok=True)
    gpus = args.gpus or [None]
    if args.warmup:  # a few seconds of training: the first block's and the evaluation's programs
        warm = out / "warmup"
        warm.mkdir(exist_ok=True)
        on_gpus(
            args.runs,
            gpus,
            lambda run, gpu: train_and_time(
                *run, args.seeds[:1], warm, out / "caches", [*args.extra, "--minutes", "0.05"], gpu
            ),
        )
    label = "warm" if args.bare_first else ""  # "": the caches are as --cold or --warmup set them
    per_process = [args.seeds] if args.vmap_seeds else [[s] for s in args.seeds]
    jobs = []
    for run in args.runs:  # with --bare-first, each run's bare job first, its warm jobs once it has ended
        jobs += [(run, args.seeds[:1], "bare")] if args.bare_first else []
        jobs += [(run, seeds, label) for seeds in per_process]
    rows, pending, lock, bare_ended = [], [], threading.Lock(), set()

    def scored(wait: bool) -> None:
        """Fill in the Gymnasium scores of the replays that have ended (``wait``: of all)."""
        for row, log, process in pending:
            if "gymnasium_return" in row:
                continue
            if wait:
                process.wait()
            if process.poll() is not None:
                row["gymnasium_return"], row["gymnasium_std"] = harness.gymnasium_score(log)

    def save() -> None:
        """The JSON so far, after every run: a session cut short keeps the runs that ended."""
        scored(wait=False)
        harness.write_json(
            args.json, finite_or_none(rows), summary=finite_or_none(summary(rows)), argv=list(argv), partial=True
        )

    def train_job(job: tuple, gpu: int | None) -> None:
        try:
            train_one(job, gpu)
        finally:
            if job[2] == "bare":
                bare_ended.add(job[0])  # its warm jobs may start (a failed bare run too: they report it)

    def train_one(job: tuple, gpu: int | None) -> None:
        (task, algo, preset), seeds, label = job
        if args.cold or label == "bare":
            caches = out / f"caches-{task}-{preset}-{seeds[0]}"
            shutil.rmtree(caches, ignore_errors=True)
        elif args.bare_first:
            caches = out / f"caches-{task}-{preset}-{args.seeds[0]}"  # those its bare run filled
        else:
            caches = out / "caches"
        place = out / label if label == "bare" else out
        for row in train_and_time(task, algo, preset, seeds, place, caches, args.extra, gpu):
            row["caches"] = label
            log = place / f"{task}-{algo}-{preset}-seed{row['seed']}-gymnasium.log"
            replay = None
            if args.episodes > 0:
                replay = harness.gymnasium_replay(Path(row["run_dir"]), log, args.episodes, train_seed=row["seed"])
            with lock:
                rows.append(row)
                if replay is not None:
                    pending.append((row, log, replay))
                print(
                    f"  {task} {algo}:{preset} seed {row['seed']}{'' if gpu is None else f' (GPU {gpu})'}: "
                    f"{row['wall_s']:.1f} s, {row['env_steps']:,.0f} env steps, in-run mean policy "
                    f"{row['in_run_mean_policy']}, exit {row['status']}",
                    flush=True,
                )
        with lock:
            save()

    if args.bare_first:
        (out / "bare").mkdir(exist_ok=True)
    on_gpus(jobs, gpus, train_job, ready=lambda job: job[2] != "warm" or job[0] in bare_ended)
    scored(wait=True)
    groups = summary(rows)
    harness.write_json(args.json, finite_or_none(rows), summary=finite_or_none(groups), argv=list(argv))
    print(f"\n{harness.describe()}")
    print(
        harness.table(
            groups,
            [
                ("task:algo:preset", lambda g: g["run"]),
                ("seeds", lambda g: g["seeds"]),
                ("Gymnasium v5, each seed", lambda g: ", ".join(map(score_text, g["scores"])) or "-"),
                ("in-run mean policy, each seed", lambda g: ", ".join(map(score_text, g["in_run"])) or "-"),
                ("median", lambda g: score_text(g["median"])),
                ("env steps", lambda g: f"{g['env_steps']:,.0f}"),
                ("whole process s", lambda g: f"{g['wall_s']:.0f}"),
                ("target", lambda g: g["verdict"]),
            ],
        )
    )
    failed = failures(rows, args.episodes)
    for line in failed:
        print(f"error: {line}", file=sys.stderr)
    if failed:
        raise SystemExit(1)


def band(curves: list[list[tuple[float, float]]], grid: list[float]) -> tuple[list[float], list[float], list[float]]:
    """Lowest, median and highest return over ``curves`` (each ``[(x, return)]``, x increasing) at
    each point of ``grid``, holding each curve's last value before that point (NaN before its
    first)."""

    def at(curve: list[tuple[float, float]], x: float) -> float:
        seen = [r for cx, r in curve if cx <= x]
        return seen[-1] if seen else math.nan

    lows, mids, highs = [], [], []
    for x in grid:
        values = [v for v in (at(c, x) for c in curves) if not math.isnan(v)]
        lows.append(min(values) if values else math.nan)
        mids.append(statistics.median(values) if values else math.nan)
        highs.append(max(values) if values else math.nan)
    return lows, mids, highs


def plot_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="suite.py plot", description=PLOT_DOC, formatter_class=RAW)
    parser.add_argument("files", nargs="+")
    parser.add_argument("--out", default="suite.png")
    args = parser.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [row for path in args.files for row in harness.rows_of(path)]
    tasks = list(dict.fromkeys(row["task"] for row in rows))
    fig, axes = plt.subplots(2, len(tasks), figsize=(4 * len(tasks), 6.5), squeeze=False)
    for column, task in enumerate(tasks):
        runs: dict[str, list[dict]] = {}
        for row in rows:
            if row["task"] == task:
                runs.setdefault(f"{row['algo']}:{row['preset']}", []).append(row)
        for axis_row, (index, label) in enumerate(((0, "training wall clock (s)"), (1, "env steps"))):
            ax = axes[axis_row][column]
            for name, seeds in runs.items():
                curves = [[(point[index], point[2]) for point in row["curve"]] for row in seeds]
                end = max((c[-1][0] for c in curves if c), default=0.0)
                grid = [end * i / 200 for i in range(201)]
                low, mid, high = band(curves, grid)
                ax.plot(grid, mid, label=name)
                ax.fill_between(grid, low, high, alpha=0.25)
            ax.set_xlabel(label)
            ax.set_ylabel("mean-policy return")
            ax.set_title(task)
            ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")


def tally(rows: Sequence[dict], bar: float) -> list[dict]:
    """One entry per setting (TASK:ALGO:PRESET and its extra flags) of the scored ``rows``: its
    seeds, how many scored at least ``bar``, the lowest and the median score, the seeds below."""
    settings: dict[tuple[str, str], dict[int, float]] = {}
    for row in rows:
        if row.get("gymnasium_return") is None:
            continue
        setting = (f"{row['task']}:{row['algo']}:{row['preset']}", " ".join(row.get("extra", [])))
        settings.setdefault(setting, {})[row["seed"]] = row["gymnasium_return"]
    out = []
    for (run, extra), scores in settings.items():
        values = list(scores.values())
        below = sorted((seed for seed, score in scores.items() if score < bar), key=scores.__getitem__)
        out.append(
            {
                "run": run,
                "extra": extra,
                "seeds": len(values),
                "reached": len(values) - len(below),
                "lowest": min(values),
                "median": statistics.median(values),
                "below": [(seed, scores[seed]) for seed in below],
            }
        )
    return out


def count_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="suite.py count", description=COUNT_DOC, formatter_class=RAW)
    parser.add_argument("files", nargs="+")
    parser.add_argument("--bar", type=float, required=True, help="the score a seed must reach")
    args = parser.parse_args(argv)
    entries = tally([row for path in args.files for row in harness.rows_of(path)], args.bar)
    print(
        harness.table(
            entries,
            [
                ("task:algo:preset", lambda e: e["run"]),
                ("extra flags", lambda e: e["extra"] or "-"),
                ("seeds", lambda e: e["seeds"]),
                (f">= {args.bar:g}", lambda e: e["reached"]),
                ("below", lambda e: f"{100 * (1 - e['reached'] / e['seeds']):.1f} %"),
                ("lowest", lambda e: score_text(e["lowest"])),
                ("median", lambda e: score_text(e["median"])),
                ("seeds below (score)", lambda e: ", ".join(f"{s} ({score_text(v)})" for s, v in e["below"]) or "-"),
            ],
        )
    )


PHYSICS_DOC = """Does a policy trained in jaxpg's fast physics lose return to Gymnasium's physics?

Every training seed's final mean policy (``jaxpg.load_policy``) of each RUN_DIR plays ``--episodes``
episodes of the task's Gymnasium env, built as ``python -m jaxpg.evaluate RUN --gymnasium`` builds
it (episode i reset with seed i), on MuJoCo's CPU, with the model's physics set to each variant:

  gymnasium        the model file's own settings (Hopper-v5: RK4, a Newton solve of up to 100
                   iterations and 50 line-search iterations);
  fast             jaxpg's fast fidelity (``jaxpg.envs.mjx_env``): Euler, 4 and 8 iterations;
  euler            Euler, the file's solver settings;
  rk4_fast_solver  the file's integrator, the fast fidelity's solver iterations.

The same simulator (MuJoCo, not MJX) runs every variant, so a difference is the physics settings'
alone. ``--actions`` chooses how the policy acts: ``run`` (the default), as the run's own
evaluations played it (its ``eval_action``, as ``python -m jaxpg.evaluate`` plays it); ``mode``
(``clip(mean)``); ``clipped_mean`` (``E[clip(a)]`` under the Gaussian, ``python -m jaxpg.evaluate
--mean-action clipped_mean``); with several, every variant is played each way. Prints each
seed's mean return and the episodes that ended early per variant (and action), then a summary of
each; ``--json`` gets every episode's return.

    python benchmarks/suite.py physics RUN_DIR --episodes 20 --workers 2 --json physics.json
    python benchmarks/suite.py physics RUN_DIR --variants gymnasium --actions mode clipped_mean --episodes 10
"""
ACTIONS = ("run", "mode", "clipped_mean")
PHYSICS_VARIANTS = ("gymnasium", "fast", "euler", "rk4_fast_solver")


def set_physics(model: Any, variant: str) -> None:
    """Give ``model.opt`` (a Gymnasium env's ``MjModel``) the integrator and solver iterations of ``variant``."""
    import mujoco

    from jaxpg.envs import mjx_env

    if variant in ("fast", "euler"):
        model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    if variant in ("fast", "rk4_fast_solver"):
        model.opt.iterations = mjx_env.FAST_SOLVER_ITERATIONS
        model.opt.ls_iterations = mjx_env.FAST_LS_ITERATIONS


def mujoco_name(integrator: int) -> str:
    """MuJoCo's name of an integrator: ``"EULER"``, ``"RK4"``, ..."""
    import mujoco

    return mujoco.mjtIntegrator(integrator).name.removeprefix("mjINT_")


def play_physics(job: tuple[str, int, str, str, int]) -> dict[str, Any]:
    """``job = (run_dir, seed, variant, action, episodes)``: the episodes of ``jaxpg.evaluate
    --gymnasium`` (``replay.evaluate_gymnasium``) under ``variant``'s physics, the policy acting by
    ``action`` (``ACTIONS``); their returns and how many ended before the time limit (a fall)."""
    import jaxpg
    from jaxpg.run.evaluation import replay

    run_dir, seed, variant, action, episodes = job
    policy = jaxpg.load_policy(run_dir, seed=seed, clipped_mean=None if action == "run" else action == "clipped_mean")
    task, env_kwargs = policy.run.task, policy.run.env_kwargs
    returns, lengths, _ = replay.evaluate_gymnasium(
        policy, task, env_kwargs, episodes, configure_model=lambda model: set_physics(model, variant)
    )
    env = replay.gymnasium_reference_env(task, env_kwargs)  # what the variant makes of the model, and the limit
    set_physics(env.unwrapped.model, variant)
    opt, limit = env.unwrapped.model.opt, env.spec.max_episode_steps
    env.close()
    physics = f"{mujoco_name(opt.integrator)} {int(opt.iterations)}/{int(opt.ls_iterations)} iterations"
    return {"run_dir": run_dir, "seed": seed, "variant": variant, "action": action, "returns": returns.tolist(),
            "early": int((lengths < limit).sum()), "mean": float(returns.mean()), "opt": physics}  # fmt: skip


def played_line(result: dict[str, Any], done: int, total: int) -> str:
    """One progress line for a finished ``play_physics`` job: ``[done/total] RUN seed S, VARIANT,
    ACTION: MEAN (E early)``."""
    where = f"{Path(result['run_dir']).name} seed {result['seed']}, {result['variant']}, {result['action']}"
    return f"[{done}/{total}] {where}: {score_text(result['mean'])} ({result['early']} early)"


def physics_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="suite.py physics", description=PHYSICS_DOC, formatter_class=RAW)
    parser.add_argument("run_dirs", nargs="+", metavar="RUN_DIR")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per seed and variant (default: 20)")
    parser.add_argument("--variants", nargs="+", choices=PHYSICS_VARIANTS, default=list(PHYSICS_VARIANTS))
    parser.add_argument(
        "--actions", nargs="+", choices=ACTIONS, default=["run"], help="how the policy acts (default: as the run does)"
    )
    parser.add_argument("--workers", type=int, default=2, help="processes playing side by side (default: 2)")
    parser.add_argument("--bar", type=float, default=3000.0, help="the score counted in the summary (default: 3000)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    os.environ["JAX_PLATFORMS"] = "cpu"  # inherited by the workers: the policies run on the CPU
    from jaxpg.run.checkpoints import policy_io

    seeds = {run_dir: policy_io.load_run_config(run_dir).seeds for run_dir in args.run_dirs}
    plays = [(v, a) for v in args.variants for a in args.actions]
    jobs = [(r, s, v, a, args.episodes) for r in args.run_dirs for s in seeds[r] for v, a in plays]
    results = []
    with multiprocessing.get_context("spawn").Pool(args.workers) as pool:
        for result in pool.imap(play_physics, jobs, chunksize=1):  # in the jobs' order, each as it is done
            results.append(result)
            print(played_line(result, len(results), len(jobs)), file=sys.stderr, flush=True)
    name = {(v, a): v if len(args.actions) == 1 else f"{v}, {a}" for v, a in plays}
    by = {(r["run_dir"], r["seed"], name[r["variant"], r["action"]]): r for r in results}
    unique = len({Path(r).name for r in seeds}) == len(seeds)
    rows = [
        {"run": Path(r).name if unique else r, "seed": s, **{n: by[r, s, n] for n in name.values()}}
        for r in seeds
        for s in seeds[r]
    ]
    columns = [("run", lambda row: row["run"]), ("seed", lambda row: row["seed"])]
    columns += [(v, lambda row, v=v: f"{score_text(row[v]['mean'])} ({row[v]['early']} early)") for v in name.values()]
    print(harness.table(rows, columns))
    for v in name.values():
        means = [row[v]["mean"] for row in rows]
        early = sum(row[v]["early"] for row in rows)
        median = score_text(statistics.median(means))
        print(f"{v}: median {median}, {sum(m >= args.bar for m in means)} of {len(means)} "
              f"seeds >= {args.bar:g}, {early} of {len(means) * args.episodes} episodes ended early")  # fmt: skip
    harness.write_json(args.json, results, argv=list(argv))


MODES = {"run": run_main, "plot": plot_main, "count": count_main, "physics": physics_main}

if __name__ == "__main__":
    if sys.argv[1:] in (["-h"], ["--help"]):  # asked for: the modes, exit status 0
        print(__doc__)
        raise SystemExit(0)
    harness.run_modes(__file__, MODES, __doc__)
