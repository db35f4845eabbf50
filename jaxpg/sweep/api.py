"""``run_sweep(spec, out_dir)``: train every run of a sweep, score it, and report it (docs/sweeps.md).

The steps, each resumable: expand and check the spec (``SweepSpec.expand``: a bad spec stops here,
before anything compiles); open the sweep directory (``SweepStore``: a resume must give the same
spec); score the chunks an earlier call trained but did not score; then, program by program, train
the runs no finished chunk holds (``jaxpg.sweep.runner``), saving each chunk as it ends and handing
its final policies to the scoring workers (``jaxpg.sweep.scoring``) while the next chunk trains;
last, the tables, statistics and figures (``jaxpg.sweep.report``).

With several processes (``jaxpg.run.host.processes.initialize`` first, then the same call in every
process) the runs are split over the devices of all of them; process 0 alone writes and scores.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

import jax
import numpy as np
from jax.experimental import multihost_utils

from jaxpg.run.host import processes
from jaxpg.run.rundir import config_io
from jaxpg.sweep import report, runner, scoring
from jaxpg.sweep.spec import SweepSpec
from jaxpg.sweep.store import SweepStore, leaves


def _finished_everywhere(store: SweepStore, count: int) -> set[int]:
    """The finished runs as process 0 reads them, the same in every process."""
    mask = np.zeros(count, np.int32)
    if processes.is_primary():
        for run in store.finished_runs():
            mask[run] = 1
    if jax.process_count() > 1:
        mask = np.asarray(multihost_utils.broadcast_one_to_all(mask))
    return {int(i) for i in np.flatnonzero(mask)}


def _score_jobs(
    spec: SweepSpec,
    record: dict[str, Any],
    arrays: dict[str, np.ndarray],
    runs: dict[int, runner.Run],
    configurations: dict[int, Any],
    episodes: int,
) -> list[scoring.ScoreJob]:
    params, obs_stats = leaves(arrays, "params"), leaves(arrays, "obs_stats")
    jobs = []
    for row, index in enumerate(record["runs"]):
        run = runs[index]
        jobs.append(
            scoring.ScoreJob(
                run=index,
                task=spec.task,
                algo=spec.algo,
                env_kwargs=spec.all_env_kwargs(),
                config=config_io.config_to_dict(configurations[run.configuration].config),
                params=[x[row] for x in params],
                obs_stats=[x[row] for x in obs_stats],
                episodes=episodes,
                seed=run.seed,
            )
        )
    return jobs


def run_sweep(
    spec: SweepSpec,
    out_dir: str | os.PathLike,
    *,
    runs_per_chunk: int = 0,
    episodes: int = 10,
    workers: int | None = None,
    max_chunks: int = 0,
    figures: bool = True,
    log: Callable[[str], None] = print,
) -> report.SweepReport | None:
    """Train, score and report ``spec`` into ``out_dir`` (module docstring).

    ``runs_per_chunk``: runs per program call (0: chosen from the devices' memory,
    ``runner.fitting_program``). ``episodes``: Gymnasium episodes per run's score (0: no scoring).
    ``workers``: scoring processes (default: the host's cores, at most 16; 0: score in this
    process). ``max_chunks`` > 0 stops after training that many chunks (the rest on a later call).
    Returns the ``SweepReport`` (``None`` when runs are left, or in a process other than 0).
    Raises ``SpecError`` (one line) for a bad spec.
    """
    env = spec.make_env()
    configurations = spec.expand(env)
    module = spec.module()
    seeds = list(spec.seeds)
    store = SweepStore(out_dir)
    primary = processes.is_primary()
    if primary:
        store.open({"spec": spec.to_json(), "configurations": [c.values for c in configurations]})
    processes.barrier("jaxpg-sweep-open")
    runs = runner.all_runs(configurations, seeds)
    by_run = {r.index: r for r in runs}
    by_config = {c.index: c for c in configurations}
    finished = _finished_everywhere(store, len(runs))
    iterations = spec.total_iterations()
    block = runner.iteration_block(iterations)
    mesh = runner.run_mesh()
    groups = runner.programs(configurations)
    log(
        f"sweep: {len(configurations)} configurations x {len(seeds)} seeds = {len(runs)} runs in {len(groups)} "
        f"program(s) on {mesh.devices.size} device(s); {len(finished)} runs already done"
    )
    scorer = None
    if primary and episodes > 0:
        scorer = scoring.Scorer(min(os.cpu_count() or 1, 16) if workers is None else workers)

    def score_chunk(name: str) -> None:
        record, arrays = store.load_chunk(name)
        jobs = _score_jobs(spec, record, arrays, by_run, by_config, episodes)
        scorer.submit(jobs, lambda scores, name=name: store.save_scores(name, scores))

    try:
        if scorer is not None:
            for name in store.chunk_names():
                if store.scores(name) is None:
                    score_chunk(name)
        trained = 0
        for group in groups:
            members = {c.index for c in group}
            todo = [r for r in runs if r.configuration in members and r.index not in finished]
            if not todo or (max_chunks and trained >= max_chunks):
                continue
            start = time.perf_counter()
            program = runner.fitting_program(module, env, group[0].config, len(todo), block, mesh, runs_per_chunk)
            compile_s = time.perf_counter() - start
            log(
                f"program {groups.index(group) + 1}/{len(groups)}: {len(todo)} runs in chunks of {program.runs} "
                f"({program.bytes_per_device / 2**20:.0f} MiB per device), compiled in {compile_s:.1f} s"
            )
            for chunk in runner.chunks_of(todo, program.runs):
                if max_chunks and trained >= max_chunks:
                    break
                result = runner.train_chunk(program, module, chunk, by_config, iterations, block, mesh, compile_s)
                compile_s = 0.0
                trained += 1
                log(f"  chunk of {len(chunk)} runs trained in {result.train_s:.1f} s")
                if primary:
                    name = store.save_chunk(result)
                    if scorer is not None:
                        score_chunk(name)
        if scorer is not None:
            scorer.wait()
    finally:
        if scorer is not None:
            scorer.close()
    processes.barrier("jaxpg-sweep-trained")
    if not primary:
        return None
    if len(store.finished_runs()) < len(runs):
        log(f"sweep: {len(runs) - len(store.finished_runs())} runs left; run the same sweep again to go on")
        return None
    result = report.build(store, spec, configurations, runs)
    result.write(store.root, figures=figures)
    return result
