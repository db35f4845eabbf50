"""``suite.py run``: every TASK:ALGO:PRESET trained for every seed, each a fresh process, scored in Gymnasium."""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

import harness

from suite_modes.verdicts import (
    failures,
    finite_or_none,
    is_finite,
    parse_run,
    score_text,
    seeds_label,
    summary,
    unknown_runs,
)

RAW = argparse.RawDescriptionHelpFormatter


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
        evaluated = [r for r in rows if is_finite(r.get("return_mean_policy"))]
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
