"""``throughput.py host``: the host's work after each block of a many-seed run."""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Sequence

import harness
import numpy as np

from jaxpg import envs

RAW = argparse.RawDescriptionHelpFormatter


HOST_DOC = """The host's work after each block of a run of many seeds, which the device waits for.

After each block (``--log-every`` iterations) the training process writes one ``metrics.jsonl``
record per iteration and seed and the same scalars to TensorBoard, redraws ``curves.png`` at
checkpoints and writes checkpoints. From synthetic metrics of ``--seeds`` seeds (``--keys``
scalars each, a block of ``--block`` iterations) this times, median of ``--repeats``:

  records   ``metrics_log.block_records`` to the sinks ``JsonlLog`` and ``TensorBoardLog`` (one
            event per iteration and seed, the block's checksums computed together);
  per_scalar  the same TensorBoard scalars as one event each, checksummed one by one (the writer
            before 2026-11-29), JSON included;
  curves    ``curves.png`` redrawn from the curves kept in memory after ``--iterations`` iterations;
  reread    the same redraw from ``metrics.jsonl`` re-read (before 2026-11-29, at every checkpoint);
  checkpoint  one checkpoint of a real training state (``--state TASK:ALGO:PRESET``, built with MJX's
            JAX implementation; off by default: building it compiles the task's reset).

    python benchmarks/throughput.py host --seeds 32 --iterations 12500 --state humanoid:a2c:humanoid_1m
"""


def host_main(argv: Sequence[str]) -> None:
    import shutil
    import tempfile
    from pathlib import Path

    from jaxpg.run.checkpoints import checkpointer
    from jaxpg.run.outputs import metrics_log, plotting, tensorboard

    parser = argparse.ArgumentParser(prog="throughput.py host", description=HOST_DOC, formatter_class=RAW)
    parser.add_argument("--seeds", type=int, default=32)
    parser.add_argument("--keys", type=int, default=22, help="scalars per record besides iteration and seed")
    parser.add_argument("--block", type=int, default=10, help="iterations per block")
    parser.add_argument("--iterations", type=int, default=12500, help="iterations drawn in curves.png")
    parser.add_argument("--state", help="TASK:ALGO:PRESET whose training state one checkpoint saves")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    names = [*plotting.CURVE_KEYS, *(f"metric_{i}" for i in range(args.keys - len(plotting.CURVE_KEYS)))]
    seeds = list(range(args.seeds))

    def block(n: int) -> dict[str, np.ndarray]:
        return {k: rng.normal(size=(n, args.seeds)).astype(np.float32) for k in names}

    work = Path(tempfile.mkdtemp(prefix="jaxpg-host-"))
    (work / "run").mkdir()
    writers = [metrics_log.JsonlLog(work / "run"), tensorboard.TensorBoardLog(work / "run", seeds)]
    per_scalar = [tensorboard.EventWriter(work / "old" / f"seed_{s}") for s in seeds]
    metrics = block(args.block)

    def write_records() -> None:
        records = metrics_log.block_records(metrics, 0, seeds, [0.0] * args.block)
        for writer in writers:
            writer.write(records)

    def write_per_scalar() -> None:
        for r in metrics_log.block_records(metrics, 0, seeds, [0.0] * args.block):
            json.dumps(r)
            for k, v in r.items():
                if k not in ("iteration", "seed") and v is not None:
                    per_scalar[r["seed"]].add_scalar(k, v, r["iteration"])

    history = plotting.CurveHistory()
    long_run = block(args.iterations)
    history.add_block(long_run, 0)
    (work / "long").mkdir()
    with (work / "long" / "metrics.jsonl").open("w") as f:
        for start in range(0, args.iterations, 500):
            part = {k: v[start : start + 500] for k, v in long_run.items()}
            for r in metrics_log.block_records(part, start, seeds, [0.0] * len(part[names[0]])):
                f.write(json.dumps(r) + "\n")
    png = work / "curves.png"
    calls = {
        "records": write_records,
        "per_scalar": write_per_scalar,
        "curves": lambda: plotting.plot_runs([("run", history)], png),
        "reread": lambda: plotting.plot_runs([("run", metrics_log.read_metrics(work / "long"))], png),
    }
    if args.state:
        from jaxpg import algos, train

        task, algo, preset = args.state.split(":")
        env = envs.make(task, impl="jax", **algos.preset_env_kwargs(algo, preset))
        module = algos.get(algo)
        state = train.init_seeds(module.init, seeds, env, module.Config(**algos.preset(algo, preset, task)))
        (work / "checkpoints").mkdir()
        saver = checkpointer.Checkpointer(work / "checkpoints", keep=2)
        step = [0]

        def save() -> None:
            step[0] += 1
            saver.save(step[0], state, score=0.0, metrics={}, info={})

        calls["checkpoint"] = save
    rows = []
    for name, call in calls.items():
        call()  # the first call imports matplotlib, opens files
        times = []
        for _ in range(args.repeats if name not in ("reread",) else max(1, min(args.repeats, 2))):
            t0 = time.perf_counter()
            call()
            times.append(time.perf_counter() - t0)
        rows.append({"work": name, "seconds": statistics.median(times), "repeats": len(times)})
        print(f"# {json.dumps(rows[-1])}", flush=True)
    for writer in writers:
        writer.close()
    for old in per_scalar:
        old.close()
    shutil.rmtree(work, ignore_errors=True)
    harness.write_json(args.json, rows, seeds=args.seeds, keys=args.keys, block=args.block, iterations=args.iterations)
    print(f"\n{harness.describe()}; {args.seeds} seeds, {args.keys} scalars, blocks of {args.block} iterations")
    columns = [("host work", lambda r: r["work"]), ("seconds (median)", lambda r: f"{r['seconds']:.3f}")]
    print(harness.table(rows, columns))
