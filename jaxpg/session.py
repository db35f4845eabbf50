"""The host side of a training run: the run directory, the training loop's callbacks, checkpoints,
evaluation between compiled calls, videos, curves, interrupts and the end-of-run report.

``jaxpg.cli`` parses a command into a ``Plan`` (nothing written or compiled yet) and hands it to
``execute``; notebooks and benchmarks can do the same with a plan of their own
(``cli.plan(argv, experiment)``) to get a run directory that ``jaxpg.evaluate``,
``jaxpg.policy_io.load_policy`` and ``--resume`` read.

    plan = jaxpg.cli.plan(["--env", "cartpole", "--iterations", "20", "--run-dir", "runs/cp"], experiment)
    status = jaxpg.session.execute(plan)    # 0: trained; 130/143: interrupted, checkpoint written

What ``execute`` guarantees: the initial state is built (and compiled) before the run directory
is touched, and the directory is locked before anything is written in it; ``--overwrite`` moves
the old run aside until the new one has a checkpoint (``recover_replaced`` finishes that for a
process killed before); SIGINT / SIGTERM finish the current compiled call, write a checkpoint and
exit with 130 / 143; write and checkpoint errors are one ``error:`` line with status 2, which says
what is on disk; process 0 alone writes files.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import functools
import json
import os
import re
import shlex
import shutil
import signal
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg import runlog
from jaxpg.runlog import RunConfig


@dataclasses.dataclass
class Plan:
    """A checked run: everything is known, nothing is written or compiled yet."""

    run: RunConfig
    run_dir: Path
    module: Any
    env: Any
    config: Any
    start: int = 0
    state: Any = None
    overwrite: bool = False
    replaced: Path | None = None  # the old run that --overwrite moved aside
    created: bool = False  # this run created its directory
    fresh: bool = False  # a new run found its directory empty, made it, or moved the old run aside
    profile: bool = False
    progress: bool | None = None
    command: list[str] = dataclasses.field(default_factory=list)
    # Stop (checkpoint written, status 0) once this many seconds have passed since the first block.
    time_limit_s: float | None = None


@functools.lru_cache(maxsize=16)
def _compiled_init(module: Any, env: Any, config: Any, seeds: tuple[int, ...]) -> Any:
    """Jitted ``init`` (several seeds: ``train.init_seeds``), cached so that runs in one process
    share the compiled program."""
    import jax

    from jaxpg import train

    if len(seeds) > 1:
        return jax.jit(lambda: train.init_seeds(module.init, seeds, env, config))
    return jax.jit(lambda key: module.init(key, env, config))


def initial_state(module: Any, env: Any, config: Any, seeds: Sequence[int]) -> Any:
    import jax

    init = _compiled_init(module, env, config, tuple(seeds))
    return init() if len(seeds) > 1 else init(jax.random.PRNGKey(seeds[0]))


def _seed_slice(tree: Any, index: int, vmap_seeds: bool) -> Any:
    import jax

    return jax.tree.map(lambda x: x[index], tree) if vmap_seeds else tree


def run_profile(plan_: Plan, ts: Any, out: Any) -> dict[str, float] | None:
    """Time each phase of one iteration (``jaxpg.run.profiling.profile_phases``)."""
    from jaxpg.run import profiling

    run = plan_.run
    if run.algo not in profiling.phased_algorithms():
        known = ", ".join(profiling.phased_algorithms())
        out(f"--profile: profiling isn't available for {run.algo} (these algorithms declare their phases: {known})")
        return None
    out(f"profiling one {run.algo} iteration as separately jitted phases (compiling them first) ...")
    _, timings = profiling.profile_phases(run.algo, _seed_slice(ts, 0, run.vmap_seeds))
    timings = {k: float(v) for k, v in timings.items()}
    total = sum(timings.values())
    samples = plan_.config.samples_per_iteration
    lines = [f"phase timings of one iteration ({samples:,} samples, seed {run.seeds[0]}):"]
    for name, seconds in timings.items():
        share = 100 * seconds / total if total > 0 else 0.0
        lines.append(f"  {name:<14} {seconds * 1e3:10.2f} ms  {share:5.1f}%")
    lines.append(f"  {'sum':<14} {total * 1e3:10.2f} ms  ({samples / total if total > 0 else 0:,.0f} samples/s)")
    out("\n".join(lines))
    return timings


class _Callbacks:
    """Host side of training: metrics, progress, summaries, checkpoints, videos, curves."""

    def __init__(
        self,
        plan_: Plan,
        checkpoints: Any,
        writer: runlog.MetricsWriter,
        progress: runlog.Progress,
        wall_offset: float,
        interrupts: Any = None,
    ):
        self.plan, self.run = plan_, plan_.run
        self.checkpoints, self.writer, self.progress = checkpoints, writer, progress
        self.wall_offset = wall_offset
        self.t_start = self.t_last = time.perf_counter()
        self.pending: list[dict[str, np.ndarray]] = []
        self.pending_steps = 0
        self.pending_time = 0.0
        self.first_block = True
        self.last_saved = plan_.start
        self.last_iteration = plan_.start
        self.block_times: list[tuple[int, float]] = []
        self.videos_enabled = self.run.video_every > 0
        self.samples = plan_.config.samples_per_iteration * len(self.run.seeds)
        self.primary = _primary()
        self.eval_seconds = 0.0
        self.evaluations = 0
        self.overflow_noted = False
        self.interrupts = interrupts
        self.clock_start: float | None = None  # end of the first block: the time limit counts from here

    def _wall(self, now: float) -> float:
        return self.wall_offset + (now - self.t_start)

    def __call__(self, ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        if self.interrupts is not None and self.interrupts.at_once:
            # A stop at once that was swallowed (raised inside a garbage-collection callback,
            # which Python ignores) takes effect here, before anything of this block is written.
            raise _StopAtOnce
        if self.interrupts is not None:
            self.interrupts.graceful = True  # a call has finished: from now on interrupts checkpoint first
        now = time.perf_counter()
        duration = now - self.t_last
        n = len(next(iter(metrics.values())))
        last = first + n
        wall_times = [self._wall(self.t_last + duration * (i + 1) / n) for i in range(n)]
        self.t_last = now
        # Evaluation ran between this block's training calls: keep it out of the training rate.
        eval_s = float(np.max(np.sum(metrics["eval_seconds"], axis=0))) if "eval_seconds" in metrics else 0.0
        self.eval_seconds += eval_s
        self.evaluations += int(np.max(np.sum(metrics.get("evaluated", np.zeros(1)), axis=0)))
        train_s = max(duration - eval_s, 1e-9)
        self.block_times.append((n, train_s))
        self.writer.write(runlog.block_records(metrics, first, self.run.seeds, wall_times))
        steps_per_s = self.samples * n / train_s
        self.progress.update(n, metrics, steps_per_s)
        self.pending.append(metrics)
        self.pending_steps += self.samples * n
        self.pending_time += train_s
        self.last_iteration = last
        at_end = last >= self.run.iterations
        self._note_overflow(metrics, first)
        if last % self.run.log_every == 0 or at_end:
            merged = {k: np.concatenate([m[k] for m in self.pending]) for k in self.pending[0]}
            rate = self.pending_steps / max(self.pending_time, 1e-9)
            note = " (incl. compile)" if self.first_block else ""
            line = runlog.summary_line(merged, last, self.run.iterations, rate, note, self.eta(last))
            self.progress.write(line)
            self._note_rejections(merged, last - len(next(iter(merged.values()))))
            self.pending, self.pending_steps, self.pending_time = [], 0, 0.0
            self.first_block = False
        if (self.run.checkpoint_every and last % self.run.checkpoint_every == 0) or at_end:
            self.save(ts, last, metrics)  # every process: gathers the state; process 0 writes
            if self.primary:
                self.plot()
        if self.primary and self.videos_enabled and (last % self.run.video_every == 0 or at_end):
            self.video(ts, last)
        if self.out_of_time(time.perf_counter()) and not at_end:
            if self.last_saved != last:
                self.save(ts, last, metrics)
                if self.primary:
                    self.plot()
            raise _TimeUp
        if self.interrupts is not None and self.interrupts.requested is not None:
            if self.last_saved != last:
                self.save(ts, last, metrics)
                if self.primary:
                    self.plot()
            raise _Stop(self.interrupts.requested)
        # Host work (checkpoints, plots, videos) is left out of the next block's throughput.
        self.t_last = time.perf_counter()

    def out_of_time(self, now: float) -> bool:
        """``plan.time_limit_s`` has passed since the end of the first block (which compiles, so
        that the limit counts training alone); never before a second block has run."""
        if self.plan.time_limit_s is None:
            return False
        if self.clock_start is None:
            self.clock_start = now
            return False
        return now - self.clock_start >= self.plan.time_limit_s

    def _note_rejections(self, metrics: dict[str, np.ndarray], first: int) -> None:
        """One line per block in which updates were rolled back (trust region or non-finite) or
        TRPO's line search accepted no step, so that a policy that stops moving says why."""
        n = len(next(iter(metrics.values())))
        rejected = np.asarray(metrics.get("update_rejected", np.zeros(n))).reshape(n, -1).max(axis=1)
        if "line_search_accepted" in metrics:
            no_step = np.asarray(metrics["line_search_accepted"]).reshape(n, -1).min(axis=1) == 0
            if no_step.any():
                self.progress.write(
                    f"warning: TRPO's line search accepted no step in {int(no_step.sum())} of iterations "
                    f"{first + 1}-{first + n} (the policy did not move; is max_kl {self.plan.config.max_kl} too large "
                    "or too small?)"
                )
        if rejected.any():
            limit = getattr(self.plan.config, "max_update_kl", 0)
            self.progress.write(
                f"warning: {int((rejected > 0).sum())} of iterations {first + 1}-{first + n} were rolled back "
                f"(mean KL above max_update_kl {limit}, or non-finite values); lower the step size or learning rate"
            )

    def eta(self, last: int) -> float | None:
        """Seconds left at the training rate measured after the first block (which compiles), plus
        the evaluations still due at their measured cost, or the time limit's remainder when that
        comes first (``--minutes``); ``None`` until a block after the first."""
        timed = self.block_times[1:]
        iterations = sum(n for n, _ in timed)
        if not iterations:
            return None
        left = self.run.iterations - last
        per_eval = self.eval_seconds / self.evaluations if self.evaluations else 0.0
        every = int(self.plan.config.eval_every) if getattr(self.plan.config, "eval_envs", 0) else 0
        evals_left = (left // every if every else 0) + (1 if every else 0)
        eta = left * sum(t for _, t in timed) / iterations + evals_left * per_eval
        if self.plan.time_limit_s is not None and self.clock_start is not None:
            eta = min(eta, max(0.0, self.plan.time_limit_s - (time.perf_counter() - self.clock_start)))
        return eta

    def _note_overflow(self, metrics: dict[str, np.ndarray], first: int) -> None:
        """One line, the first time the physics reports an overflow (MuJoCo Warp's solver at its
        iteration limit, or a full contact buffer); afterwards only the metric counts them."""
        if self.overflow_noted or "physics_overflow" not in metrics:
            return
        counts = np.asarray(metrics["physics_overflow"]).reshape(len(metrics["physics_overflow"]), -1).sum(axis=1)
        hits = np.flatnonzero(counts > 0)
        if hits.size:
            self.overflow_noted = True
            row = int(hits[0])
            self.progress.write(
                f"note: the physics hit a solver or buffer limit in {counts[row]:.0f} of "
                f"{self.samples:,} env steps of iteration {first + row + 1} (MuJoCo Warp overflow flags; "
                "counted per iteration in metrics.jsonl as physics_overflow, not reported again)"
            )

    def save(self, ts: Any, step: int, metrics: dict[str, np.ndarray]) -> None:
        last_metrics = {
            k: float(np.nanmean(v[-1])) if not np.all(np.isnan(v[-1])) else None for k, v in metrics.items()
        }
        self.checkpoints.save(
            step,
            ts,
            score=runlog.checkpoint_score(metrics, evaluated=getattr(self.plan.config, "eval_envs", 0) > 0),
            metrics=last_metrics,
            info={"task": self.run.task, "algo": self.run.algo, "seeds": self.run.seeds},
        )
        self.last_saved = step

    def plot(self) -> None:
        try:
            from jaxpg import plotting

            plotting.plot_run(self.plan.run_dir, task_score_name=self.plan.env.task_score_name)
        except Exception as e:  # noqa: BLE001 - a plot must never stop training
            self.progress.write(f"warning: curves.png not updated ({type(e).__name__}: {e})")

    def video(self, ts: Any, step: int) -> None:
        from jaxpg import evaluate as evaluate_lib
        from jaxpg import mesh as mesh_lib

        path = self.plan.run_dir / runlog.VIDEO_DIR / f"iter_{step:06d}.mp4"
        try:
            # Host copies: the video is recorded by process 0 alone, off the training mesh.
            params = _seed_slice(mesh_lib.host_copy(ts.params), 0, self.run.vmap_seeds)
            stats = _seed_slice(mesh_lib.host_copy(ts.obs_stats), 0, self.run.vmap_seeds)
            out, ret, length = evaluate_lib.record_policy(self.plan.env, ts.policy, params, stats, path, seed=step)
            self.progress.write(
                f"video {out} (mean policy, seed {self.run.seeds[0]}: return {ret:.1f}, {length} steps)"
            )
        except Exception as e:  # noqa: BLE001 - videos are optional: warn once, go on training
            self.videos_enabled = False
            self.progress.write(f"warning: videos disabled: {type(e).__name__}: {e}")


def _primary() -> bool:
    """This process writes files and prints (``jaxpg.run.processes.is_primary``)."""
    from jaxpg.run import processes

    return processes.is_primary()


def _print(line: str) -> None:
    if _primary():
        print(line, flush=True)


class _Silent:
    """Metrics writer and progress of the processes other than 0, which write nothing."""

    def write(self, *args: Any) -> None:
        pass

    def add_text(self, *args: Any) -> None:
        pass

    def update(self, *args: Any) -> None:
        pass

    def close(self) -> None:
        pass


REPLACED = ".replaced-"  # RUN.replaced-PID: the run that process PID's --overwrite moved aside
NEW = ".new-"  # RUN.new-PID: the empty, locked directory that takes RUN's place


def resume_command(run_dir: str | os.PathLike) -> str:
    """The command that continues ``run_dir``, quoted for a POSIX shell."""
    return f"python -m jaxpg.cli --resume {shlex.quote(str(run_dir))}"


def has_checkpoint(run_dir: str | os.PathLike) -> bool:
    """Whether ``run_dir`` holds a committed checkpoint (a step ``--resume`` could start from);
    ``True`` as well when its checkpoint directory cannot be read, so that nothing is taken for
    empty that is not known to be."""
    from jaxpg import checkpoint as ckpt_lib

    directory = Path(run_dir) / runlog.CHECKPOINT_DIR
    if not directory.is_dir():
        return False
    try:
        checkpoints = ckpt_lib.Checkpointer(directory, keep=None)
        try:
            return bool(checkpoints.steps())
        finally:
            checkpoints.close()
    except (OSError, ckpt_lib.CheckpointError):
        return True


def is_replaceable(run_dir: str | os.PathLike) -> bool:
    """``runlog.check_replaceable`` as a yes or no."""
    try:
        runlog.check_replaceable(run_dir)
    except (OSError, runlog.RunDirError):
        return False
    return True


def exists_message(run_dir: Path) -> str:
    """Why a new run cannot go into the existing, non-empty ``run_dir``, and what to do instead."""
    if not is_replaceable(run_dir):
        return f"run directory {str(run_dir)!r} exists and is not a jaxpg run; choose another --run-dir"
    if not has_checkpoint(run_dir):
        return (
            f"run directory {str(run_dir)!r} holds a run that has no checkpoint (it stopped before its first one, "
            "so there is nothing to resume); pass --overwrite to start it again"
        )
    return (
        f"run directory {str(run_dir)!r} exists; pass --overwrite to replace it or --resume "
        f"{shlex.quote(str(run_dir))} to continue it"
    )


def prepare_run_dir(plan_: Plan, lock: runlog.RunLock) -> float:
    """Lock the run directory, then create (or replace, or reopen) it; returns the wall-time offset.

    ``lock`` is taken before anything is written, so that a second writer is refused without
    having changed a byte. A new run then checks the directory again (another process may have
    written it since the command was planned): it must be empty, or with ``--overwrite`` a jaxpg
    run (``runlog.check_replaceable``). ``--overwrite`` moves the old run aside, beside the
    directory a symbolic link points to (the link stays a link), to ``RUN.replaced-PID``, and an
    empty locked directory takes its place; the old run is deleted once the new run has written a
    checkpoint, and put back if the new run stops before (``finish_run_dir``), so that nothing
    on disk is lost to a run that never got going.
    """
    run_dir, run = plan_.run_dir, plan_.run
    if plan_.start > 0:
        _note_stale_lock(lock.acquire(), run_dir)
        wall_offset = runlog.truncate_metrics(run_dir, plan_.start)
        history = run.info.setdefault("resumes", [])
        history.append(
            {
                "from_iteration": plan_.start,
                "command": shlex.join(plan_.command),
                "time": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
            }
        )
        run.save(run_dir)
        return wall_offset
    real = run_dir.resolve()
    created = not real.exists()
    real.mkdir(parents=True, exist_ok=True)
    _note_stale_lock(lock.acquire(), run_dir)
    if any(entry.name != runlog.LOCK_FILE for entry in real.iterdir()):
        if not plan_.overwrite:
            raise runlog.RunDirError(exists_message(run_dir) + " (it was written after this command started)")
        runlog.check_replaceable(real, shown=run_dir)
        plan_.replaced = _move_aside(real, lock)
    plan_.created, plan_.fresh = created, True
    run.info = runlog.provenance([sys.argv[0], *plan_.command])
    run.save(real)
    return 0.0


def _note_stale_lock(stale: dict[str, Any] | None, run_dir: Path) -> None:
    if stale is not None:
        who = f"process {stale['pid']}" if "pid" in stale else "a process"
        print(
            f"note: took over {str(run_dir / runlog.LOCK_FILE)!r}, left by {who} that has ended",
            file=sys.stderr,
        )


def _move_aside(real: Path, lock: runlog.RunLock) -> Path:
    """Put an empty directory, already locked by ``lock``, in the place of the run in ``real``;
    returns where the old run went (``real.replaced-PID``, this process's lock file removed)."""
    fresh = real.with_name(f"{real.name}{NEW}{os.getpid()}")
    replaced = real.with_name(f"{real.name}{REPLACED}{os.getpid()}")
    fresh.mkdir()
    try:
        lock.copy_to(fresh)
        real.rename(replaced)
    except OSError:
        shutil.rmtree(fresh, ignore_errors=True)
        raise
    try:
        fresh.rename(real)
    except OSError:
        replaced.rename(real)
        shutil.rmtree(fresh, ignore_errors=True)
        raise
    (replaced / runlog.LOCK_FILE).unlink(missing_ok=True)
    return replaced


def _put_back(replaced: Path, real: Path) -> None:
    """Move the run in ``replaced`` back to ``real``, deleting what is there (a run without a checkpoint)."""
    if not real.exists() and not real.is_symlink():
        replaced.rename(real)
        return
    abandoned = real.with_name(f"{real.name}.abandoned-{os.getpid()}")
    real.rename(abandoned)
    replaced.rename(real)
    shutil.rmtree(abandoned, ignore_errors=True)


def finish_run_dir(plan_: Plan, checkpointed: bool) -> str:
    """After the run: drop the run it replaced once the new one has a checkpoint; otherwise (it
    stopped before its first checkpoint) put back what was there (the old run, or nothing), so
    that the same command can simply be run again. Returns a note for the user ('' if none), which
    says where things are."""
    run_dir = plan_.run_dir
    if plan_.start > 0 or not plan_.fresh:
        return ""
    if checkpointed:
        if plan_.replaced is not None:
            shutil.rmtree(plan_.replaced, ignore_errors=True)
        return ""
    real = run_dir.resolve()
    if plan_.replaced is not None:
        _put_back(plan_.replaced, real)
        return f"; the run it was replacing is back in {run_dir}"
    if plan_.created:
        shutil.rmtree(real, ignore_errors=True)
        return f"; {run_dir} was removed (no checkpoint had been written)"
    for entry in real.iterdir():  # it was empty before this run
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
    return f"; {run_dir} is empty again (no checkpoint had been written)"


def _dead_siblings(real: Path, mark: str) -> list[tuple[Path, int]]:
    """The siblings ``<name><mark><pid>`` of ``real`` whose process (on this host) has ended."""
    prefix = real.name + mark
    found = []
    for path in real.parent.iterdir():
        pid = path.name[len(prefix) :]
        if path.name.startswith(prefix) and pid.isdigit() and int(pid) != os.getpid():
            if not runlog.pid_alive(int(pid)):
                found.append((path, int(pid)))
    return sorted(found, key=lambda item: item[1])


def recover_replaced(run_dir: str | os.PathLike) -> list[str]:
    """Finish what an ``--overwrite`` of ``run_dir`` left undone when its process was killed
    before it could (``kill -9``, a power cut): returns the lines that tell the user.

    A ``RUN.replaced-PID`` beside the run directory (beside the directory a symbolic link points
    to) whose process has ended is the run that ``--overwrite`` moved aside. When ``RUN`` holds
    no checkpoint (the new run never got going; it is removed) or is gone, the old run is put
    back; otherwise both stay and the note says where the old one is. A live writer of ``RUN``
    is left alone (the command is refused by its lock anyway).
    """
    run_dir = Path(run_dir)
    real = run_dir.resolve()
    if not real.parent.is_dir():
        return []
    for fresh, _ in _dead_siblings(real, NEW):  # never took RUN's place: holds the dead lock at most
        if set(os.listdir(fresh)) <= {runlog.LOCK_FILE}:
            shutil.rmtree(fresh, ignore_errors=True)
    aside = _dead_siblings(real, REPLACED)
    if not aside or (real.exists() and runlog.lock_holder(real) is not None):
        return []
    shown = " and ".join(shlex.quote(str(path)) for path, _ in aside)
    pids = ", ".join(str(pid) for _, pid in aside)
    if real.is_dir() and has_checkpoint(real):
        return [
            f"note: {shown} holds the run that an --overwrite of {run_dir} moved aside (process {pids} ended "
            f"before deleting it); {run_dir} holds the new run: delete {shown} once you no longer need it"
        ]
    if len(aside) > 1 or (real.exists() and not is_replaceable(real)):
        return [
            f"note: {run_dir} holds no checkpoint, and {shown} hold what an --overwrite moved aside (process "
            f"{pids} ended first): move back by hand the one you want"
        ]
    path, pid = aside[0]
    lock = runlog.RunLock(real)
    if real.exists():
        lock.acquire()  # takes over the dead process's lock; goes with the directory it locks
    try:
        (path / runlog.LOCK_FILE).unlink(missing_ok=True)  # the dead process's lock on the old run
        _put_back(path, real)
    finally:
        lock.release()
    return [
        f"note: an --overwrite of {run_dir} (process {pid}) ended before its first checkpoint; the run it was "
        f"replacing is back in {run_dir} (from {path})"
    ]


class _Stop(Exception):
    """Raised by the callbacks after an interrupt, once the current compiled call has finished and
    its checkpoint is written."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class _TimeUp(Exception):
    """Raised by the callbacks when ``Plan.time_limit_s`` has passed, once the block's checkpoint
    is written."""


class _StopAtOnce(KeyboardInterrupt):
    """The ``KeyboardInterrupt`` that ``_Interrupts`` raises to stop at once.

    A subclass, not ``KeyboardInterrupt`` itself: CPython remembers a bare ``KeyboardInterrupt``
    that passes through code run by its C API (``PyRun_*``, as some imports are), and at exit
    then kills the process by SIGINT (status -2) even though the run caught the interrupt and
    returned 130. It compares the exception's exact type, so a subclass leaves the exit status
    to the run.
    """


class _Interrupts:
    """SIGINT and SIGTERM. Once the first compiled call has finished (``graceful``), the first
    signal asks to stop after the current call (``requested``) and a second SIGINT stops at once;
    before that (building the state, compiling) any of them stops at once (``KeyboardInterrupt``),
    so that an interrupted start leaves nothing behind. Only in a single-process run: several
    processes must agree on when to stop, which they cannot here.

    Python runs signal handlers only between its own instructions, so while the main thread waits
    in a compiled call or a compilation that does not return, they would not run at all. A
    watcher thread sees every signal as it arrives (``signal.set_wakeup_fd``); when one that
    should stop at once (before the first call has finished, or a second signal) is not handled
    within ``HARD_STOP_S`` seconds, it prints one line and ends the process at once (status
    128 + signal). A run directory it leaves keeps a stale lock, which the next run takes over."""

    HARD_STOP_S = 5.0

    def __init__(self) -> None:
        self.requested: int | None = None
        self.graceful = False
        self.at_once = False  # a stop at once was raised (it may have been swallowed or wrapped)
        self.previous: dict[int, Any] = {}
        self.handled = 0  # signals the Python-level handler has run for
        self._wakeup: tuple[int, int] | None = None  # the pipe the C-level handler writes signals to
        self._previous_wakeup_fd = -1

    def __enter__(self) -> _Interrupts:
        import jax

        if jax.process_count() == 1:
            for signum in (signal.SIGINT, signal.SIGTERM):
                self.previous[signum] = signal.signal(signum, self._handle)
            if threading.current_thread() is threading.main_thread():
                read_fd, write_fd = os.pipe()
                os.set_blocking(write_fd, False)
                self._previous_wakeup_fd = signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
                self._wakeup = (read_fd, write_fd)
                threading.Thread(target=self._watch, args=(read_fd,), daemon=True, name="jaxpg-interrupts").start()
        self.previous_unraisablehook = sys.unraisablehook
        sys.unraisablehook = self._unraisable
        return self

    def _watch(self, read_fd: int) -> None:
        """The watcher thread: counts the SIGINT/SIGTERM that arrive and ends the process when
        one that should stop at once is left unhandled (the main thread is stuck outside Python)."""
        arrived = 0
        while True:
            try:
                data = os.read(read_fd, 64)
            except OSError:
                data = b""
            if not data:  # __exit__ closed the pipe's other end
                os.close(read_fd)
                return
            signums = [b for b in data if b in (signal.SIGINT, signal.SIGTERM)]
            if not signums:
                continue
            arrived += len(signums)
            if self.graceful and arrived < 2:
                continue  # the current call finishes, then a checkpoint is written: that may take long
            deadline = time.monotonic() + self.HARD_STOP_S
            while time.monotonic() < deadline and self.handled < arrived:
                time.sleep(0.05)
            if self.handled < arrived and self._wakeup is not None:
                name = signal.Signals(signums[-1]).name
                os.write(
                    2,
                    f"\n{name}: stopped at once: a compiled call or compilation did not return to Python within "
                    f"{self.HARD_STOP_S:g} s (continue from the latest checkpoint, if any, with --resume)\n".encode(),
                )
                os._exit(_exit_status(signums[-1]))

    def _unraisable(self, report: Any) -> None:
        """Python's report of an exception it could not raise (one raised in a garbage-collection
        callback): silent for a stop at once, which the next callback raises again."""
        if not isinstance(report.exc_value, _StopAtOnce):
            self.previous_unraisablehook(report)

    def _handle(self, signum: int, frame: Any) -> None:
        self.handled += 1
        at_once = not self.graceful or (self.requested is not None and signum == signal.SIGINT)
        self.requested = signum if self.requested is None else self.requested
        if at_once:
            self.requested = signum
            self.at_once = True
            raise _StopAtOnce

    @contextlib.contextmanager
    def attributed(self) -> Any:
        """Any exception raised after a stop at once becomes ``_StopAtOnce``.

        The handler raises wherever the main thread is, so its exception can come back wrapped (a
        C extension's import turns it into ``ImportError``); whatever follows the request is
        part of stopping."""
        try:
            yield
        except KeyboardInterrupt:
            raise
        except BaseException as exc:
            if self.at_once:
                raise _StopAtOnce from exc
            raise

    def __exit__(self, *exc: Any) -> None:
        if self._wakeup is not None:
            signal.set_wakeup_fd(self._previous_wakeup_fd)
            _, write_fd = self._wakeup
            self._wakeup = None
            os.close(write_fd)  # the watcher reads the end of the pipe, closes its end and returns
        for signum, handler in self.previous.items():
            signal.signal(signum, handler)
        sys.unraisablehook = self.previous_unraisablehook


def _exit_status(signum: int) -> int:
    return 128 + int(signum)


def execute(plan_: Plan) -> int:
    """Train as planned; returns the exit status.

    The initial state is built (and its program compiled) before the run directory is touched.
    SIGINT / SIGTERM finish the current compiled call, write a checkpoint, print one line and exit
    with 130 / 143; a second SIGINT exits at once. Write errors (disk full, permissions) and
    checkpoint errors are one ``error:`` line with status 2.
    """
    from jaxpg.run import processes

    run, run_dir = plan_.run, plan_.run_dir
    primary = _primary()
    if plan_.start > 0 and plan_.start >= run.iterations:
        _print(
            f"nothing to do: {run_dir} has done {plan_.start} iterations and --iterations asks for {run.iterations} "
            "(nothing was written; raise --iterations to train on)"
        )
        return 0
    with _Interrupts() as interrupts:
        try:
            with interrupts.attributed():
                ts = plan_.state
                if ts is None:
                    ts = initial_state(plan_.module, plan_.env, plan_.config, run.seeds)
        except KeyboardInterrupt:
            name = signal.Signals(interrupts.requested or signal.SIGINT).name
            print(f"\n{name}: stopped before training started; nothing was written", file=sys.stderr)
            return _exit_status(interrupts.requested or signal.SIGINT)
        # Process 0 writes the run directory once every process has checked it, before any reads it.
        processes.barrier("jaxpg: planned")
        lock = runlog.RunLock(run_dir)
        try:
            try:
                wall_offset = prepare_run_dir(plan_, lock) if primary else 0.0
            except (OSError, runlog.RunDirError) as e:
                note = finish_run_dir(plan_, checkpointed=False) if primary else ""
                what = (
                    f"cannot write the run directory {str(run_dir)!r}: {e.strerror or e}"
                    if isinstance(e, OSError)
                    else e
                )
                print(f"error: {what}{note}", file=sys.stderr)
                return 2
            with interrupts.attributed():
                return _train(plan_, ts, wall_offset, interrupts)
        except KeyboardInterrupt:
            # While writing the run directory or between that and the training loop's own handler
            # (imports, profiling, device placement): the same clean-up as an interrupt in the
            # first block.
            note = finish_run_dir(plan_, checkpointed=plan_.start > 0) if primary else ""
            resume = f"; continue with: {resume_command(run_dir)}" if plan_.start > 0 else ""
            signum = interrupts.requested or signal.SIGINT
            print(f"\n{signal.Signals(signum).name}: stopped at once{resume}{note}", file=sys.stderr)
            return _exit_status(signum)
        finally:
            lock.release()


def _train(plan_: Plan, ts: Any, wall_offset: float, interrupts: _Interrupts) -> int:
    """The training loop of ``execute``, in a prepared and locked run directory."""
    import jax

    from jaxpg import checkpoint as ckpt_lib
    from jaxpg import mesh as mesh_lib
    from jaxpg import train
    from jaxpg.algos import core
    from jaxpg.run import processes

    run, run_dir = plan_.run, plan_.run_dir
    primary = _primary()
    processes.barrier("jaxpg: run directory ready")
    verb = f"resuming at iteration {plan_.start}" if plan_.start else "training"
    seeds = " ".join(map(str, run.seeds))
    _print(
        f"{verb}: {run.algo} on {run.task} ({plan_.env!r}), seed{'s' if len(run.seeds) > 1 else ''} {seeds}, "
        f"{run.iterations} iterations of {plan_.config.samples_per_iteration:,} samples, "
        f"{jax.device_count()} {jax.devices()[0].device_kind} device(s)"
        f"{f' in {jax.process_count()} processes' if jax.process_count() > 1 else ''} -> {run_dir}"
    )
    update, evaluate = plan_.module.update, train.evaluate_state
    mesh = mesh_lib.env_mesh() if run.shard else None
    if mesh is not None:
        # The env batch splits over the mesh: sampling under shard_map, learning under jit's partitioner.
        ts = core.shard_state(ts, run.vmap_seeds, mesh)
        update = mesh_lib.on_mesh(update, mesh)
        evaluate = mesh_lib.on_mesh(evaluate, mesh)
    if plan_.profile:
        with jax.set_mesh(mesh) if mesh is not None else contextlib.nullcontext():
            timings = run_profile(plan_, ts, _print)
        if timings is not None and primary:
            runlog.write_json_atomic(run_dir / "profile.json", {"phases_s": timings, "iteration": plan_.start})
    remaining = run.iterations - plan_.start
    if remaining <= 0:
        _print(f"nothing to do: {run_dir} has done {plan_.start} of {run.iterations} iterations (raise --iterations)")
        return 0
    checkpoints = writer = progress = None
    status = 0
    failure: str | None = None  # the error line, once the run directory is put in order
    kept = ""  # what the error line adds when the run keeps its checkpoints
    callbacks: _Callbacks | None = None
    try:
        with interrupts.attributed():
            checkpoints = ckpt_lib.Checkpointer(run_dir / runlog.CHECKPOINT_DIR, keep=run.keep_checkpoints, create=True)
            writer = runlog.MetricsWriter(run_dir, run.seeds, start_iteration=plan_.start) if primary else _Silent()
            if plan_.start == 0:
                writer.add_text("config", "```\n" + json.dumps(run.to_json(), indent=2) + "\n```")
            progress = (
                runlog.Progress(
                    run.iterations, initial=plan_.start, enabled=plan_.progress, desc=f"{run.algo} {run.task}"
                )
                if primary
                else _Silent()
            )
            callbacks = _Callbacks(plan_, checkpoints, writer, progress, wall_offset, interrupts)
            block = run.block_size
            # Blocks start at multiples of block_size, as in an uninterrupted run.
            segments = []
            misaligned = (-plan_.start) % block
            if misaligned:
                segments.append(min(misaligned, remaining))
            if remaining - sum(segments) > 0:
                segments.append(remaining - sum(segments))
            for index, count in enumerate(segments):
                ts = train.train(
                    update,
                    ts,
                    count,
                    block_size=min(block, count),
                    callbacks=[callbacks],
                    seeds=run.vmap_seeds,
                    evaluate=evaluate,
                    final_eval=index == len(segments) - 1,  # the run's last iteration is always evaluated
                )
    except _Stop as stop:
        progress.close()
        print(
            f"{stop}: stopped after iteration {callbacks.last_iteration}, checkpoint {callbacks.last_saved} written. "
            f"Continue with: {resume_command(run_dir)}",
            file=sys.stderr,
        )
        status = _exit_status(stop.signum)
    except KeyboardInterrupt:
        if progress is not None:
            progress.close()
        saved = callbacks.last_saved if callbacks is not None else plan_.start
        note = finish_run_dir(plan_, checkpointed=saved > 0) if primary else ""
        resume = f"; continue from checkpoint {saved} with: {resume_command(run_dir)}" if saved else ""
        signum = interrupts.requested or signal.SIGINT
        print(f"\n{signal.Signals(signum).name}: stopped at once{resume}{note}", file=sys.stderr)
        return _exit_status(signum)
    except _TimeUp:
        progress.close()
        _print(
            f"time limit of {plan_.time_limit_s / 60:g} min reached after iteration {callbacks.last_iteration} "
            f"(checkpoint written; continue with: {resume_command(run_dir)})"
        )
    except train.TrainingDiverged as e:
        progress.close()
        failure, kept = str(e), f"; metrics and checkpoints up to then are in {run_dir}"
        status = 1
    except (OSError, ckpt_lib.CheckpointError) as e:
        if progress is not None:
            progress.close()
        what = f"{e.strerror}: {e.filename}" if isinstance(e, OSError) and e.strerror else str(e).splitlines()[0]
        hint = " (disk full?)" if isinstance(e, OSError) and e.errno == 28 else ""
        failure, kept = f"writing the run directory failed: {what}{hint}", ""
        status = 2
    finally:
        for closable in (progress, writer, checkpoints):
            if closable is not None:
                try:
                    closable.close()
                except Exception:  # noqa: BLE001 - closing after a failure must not hide it
                    pass
    saved = callbacks.last_saved if callbacks is not None else plan_.start
    note = finish_run_dir(plan_, checkpointed=saved > 0) if primary else ""
    if failure is not None:
        # Without a checkpoint there is nothing to resume: the note says what is on disk instead.
        print(f"error: {_without_resume_advice(failure) + note if note else failure + kept}", file=sys.stderr)
    elif note:
        print(f"the run stopped before its first checkpoint{note}", file=sys.stderr)
    if status == 0 and primary:
        _report_end(plan_, callbacks)
    processes.barrier("jaxpg: done")  # the processes leave together (JAX's shutdown waits for all)
    return status


def _without_resume_advice(message: str) -> str:
    """``message`` without a closing advice to continue with ``--resume``."""
    return re.sub(r"[,;]?\s*(then )?continue with --resume\b.*$", "", message)


def _report_end(plan_: Plan, callbacks: _Callbacks) -> None:
    run, run_dir = plan_.run, plan_.run_dir
    # The first block includes compilation.
    timed = callbacks.block_times[1:]
    iters = sum(n for n, _ in timed)
    secs = sum(t for _, t in timed)
    total = sum(t for _, t in callbacks.block_times)
    total += callbacks.eval_seconds
    if iters and secs > 0:
        rate = callbacks.samples * iters / secs
        _print(f"done in {total:.1f} s: {secs / iters:.3f} s per iteration, {rate:,.0f} env steps/s after compilation")
    else:
        _print(f"done in {total:.1f} s (including compilation)")
    if callbacks.evaluations:
        share = 100 * callbacks.eval_seconds / max(total, 1e-9)
        _print(
            f"evaluation: {callbacks.evaluations} of the mean policy ({run.config.get('eval_envs')} episodes each), "
            f"{callbacks.eval_seconds:.1f} s ({share:.1f}% of the training loop's wall clock)"
        )
    if plan_.profile and iters:
        seeds = f", {len(run.seeds)} seeds vmapped" if run.vmap_seeds else ""
        _print(f"fused update (scan of {run.block_size} iterations{seeds}): {secs / iters * 1e3:.2f} ms per iteration")
    try:
        from jaxpg import checkpoint as ckpt_lib

        checkpoints = ckpt_lib.Checkpointer(run_dir / runlog.CHECKPOINT_DIR, keep=None)
        # Both verified: a damaged step is skipped (with a warning line), never recommended.
        best, latest = checkpoints.resolve_step("best"), checkpoints.resolve_step("latest")
        if best is not None and best != latest:
            score = checkpoints.score(best)
            _print(f"best checkpoint: iteration {best} (return {score:.1f}); evaluate it with --step best")
        checkpoints.close()
    except ValueError:
        pass
    _print(f"run directory: {run_dir}  (metrics.jsonl, curves.png, tensorboard/, checkpoints/)")
    if run.task == "atari_pong":  # the real game is ALE's: play it there
        _print(f"evaluate: python -m jaxpg.evaluate {shlex.quote(str(run_dir))} --ale --episodes 10 [--no-sticky]")
        return
    from jaxpg import evaluate

    gymnasium = " [--gymnasium]" if run.task in evaluate.GYMNASIUM_IDS else ""
    quoted = shlex.quote(str(run_dir))
    video = f"[--video {shlex.quote(str(run_dir / runlog.VIDEO_DIR / 'final.mp4'))}]"
    _print(f"evaluate: python -m jaxpg.evaluate {quoted} --episodes 10{gymnasium} {video}")
