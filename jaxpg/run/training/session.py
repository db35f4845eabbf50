"""A training run on the host: lock and prepare the run directory (``replacing``), train with the
host's callbacks (``callbacks``) under the interrupt handlers (``interrupts``), put the directory
in order and report.

``jaxpg.cli`` parses a command into a ``Plan`` (nothing written or compiled yet) and hands it to
``execute``; notebooks and benchmarks can do the same with a plan of their own
(``planning.plan(argv, experiment)``) to get a run directory that ``jaxpg.evaluate``,
``jaxpg.run.checkpoints.policy_io.load_policy`` and ``--resume`` read.

    argv = ["--env", "cartpole", "--iterations", "20", "--run-dir", "runs/cp"]
    plan = jaxpg.run.command.planning.plan(argv, experiment)
    status = jaxpg.run.training.session.execute(plan)    # 0: trained; 130/143: interrupted, checkpoint written

What ``execute`` guarantees: the initial state is built (and compiled) before the run directory
is touched, and the directory is locked before anything is written in it; ``--overwrite`` moves
the old run aside until the new one has a checkpoint (``recover_replaced`` finishes that for a
process killed before); SIGINT / SIGTERM finish the current compiled call, write a checkpoint and
exit with 130 / 143; write and checkpoint errors are one ``error:`` line with status 2, which says
what is on disk; process 0 alone writes files.
"""

from __future__ import annotations

import contextlib
import json
import re
import shlex
import signal
import sys
import time
from typing import Any

import jax

from jaxpg import mesh as mesh_lib
from jaxpg import train
from jaxpg.algos import core
from jaxpg.envs.warp_kernels import KernelBuild
from jaxpg.run.checkpoints import checkpoint_errors, checkpointer
from jaxpg.run.command.plan import Plan, initial_state
from jaxpg.run.evaluation import replay
from jaxpg.run.host import processes, profiling
from jaxpg.run.outputs import console, sinks
from jaxpg.run.outputs.output import Silent, is_primary, seed_slice, show
from jaxpg.run.rundir import layout, run_lock
from jaxpg.run.rundir.interrupts import Interrupts, Stop, TimeUp, exit_status
from jaxpg.run.rundir.replacing import finish_run_dir, prepare_run_dir, resume_command, stopped_at_once_note
from jaxpg.run.training.callbacks import BlockClock, HostCallbacks, host_callbacks


def run_profile(plan_: Plan, ts: Any, out: Any) -> dict[str, float] | None:
    """Time each phase of one iteration (``jaxpg.run.host.profiling.profile_phases``)."""
    run = plan_.run
    if run.algo not in profiling.phased_algorithms():
        known = ", ".join(profiling.phased_algorithms())
        out(f"--profile: profiling isn't available for {run.algo} (these algorithms declare their phases: {known})")
        return None
    out(f"profiling one {run.algo} iteration as separately jitted phases (compiling them first) ...")
    _, timings = profiling.profile_phases(run.algo, seed_slice(ts, 0, run.vmap_seeds))
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


def execute(plan_: Plan) -> int:
    """Train as planned; returns the exit status.

    The initial state is built (and its program compiled) before the run directory is touched.
    SIGINT / SIGTERM finish the current compiled call, write a checkpoint, print one line and exit
    with 130 / 143; a second SIGINT exits at once, and never removes a run directory that holds a
    checkpoint (``replacing.finish_run_dir`` looks at the disk). Write errors (disk full,
    permissions) and checkpoint errors are one ``error:`` line with status 2; a run that diverges
    (``jaxpg.run.training.divergence``) is one ``error:`` line with status 1, its last good checkpoint kept.
    """
    run, run_dir = plan_.run, plan_.run_dir
    primary = is_primary()
    if plan_.start > 0 and plan_.start >= run.iterations:
        show(
            f"nothing to do: {run_dir} has done {plan_.start} iterations and --iterations asks for {run.iterations} "
            "(nothing was written; raise --iterations to train on)"
        )
        return 0
    with Interrupts() as interrupts:
        try:
            with interrupts.attributed():
                ts = plan_.state
                if ts is None:
                    ts = initial_state(plan_.module, plan_.env, plan_.config, run.seeds)
                if plan_.startup is not None:
                    plan_.startup.state_ready = time.perf_counter()
        except KeyboardInterrupt:
            name = signal.Signals(interrupts.requested or signal.SIGINT).name
            print(f"\n{name}: stopped before training started; nothing was written", file=sys.stderr)
            return exit_status(interrupts.requested or signal.SIGINT)
        # Process 0 writes the run directory once every process has checked it, before any reads it.
        processes.barrier("jaxpg: planned")
        lock = run_lock.RunLock(run_dir)
        try:
            try:
                wall_offset = prepare_run_dir(plan_, lock) if primary else 0.0
            except (OSError, layout.RunDirError) as e:
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
            note = stopped_at_once_note(plan_, checkpointed=plan_.start > 0) if primary else ""
            signum = interrupts.requested or signal.SIGINT
            print(f"\n{signal.Signals(signum).name}: stopped at once{note}", file=sys.stderr)
            return exit_status(signum)
        finally:
            lock.release()


def _train(plan_: Plan, ts: Any, wall_offset: float, interrupts: Interrupts) -> int:
    """The training loop of ``execute``, in a prepared and locked run directory."""
    run, run_dir = plan_.run, plan_.run_dir
    primary = is_primary()
    processes.barrier("jaxpg: run directory ready")
    verb = f"resuming at iteration {plan_.start}" if plan_.start else "training"
    seeds = " ".join(map(str, run.seeds))
    show(
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
            timings = run_profile(plan_, ts, show)
        if timings is not None and primary:
            layout.write_json_atomic(run_dir / "profile.json", {"phases_s": timings, "iteration": plan_.start})
    remaining = run.iterations - plan_.start
    if remaining <= 0:
        show(f"nothing to do: {run_dir} has done {plan_.start} of {run.iterations} iterations (raise --iterations)")
        return 0
    # MuJoCo Warp's kernels build on all cores while XLA compiles the first block. Its dry run must
    # not overlap a program that launches them: the initial state's is finished first.
    jax.block_until_ready(ts)
    first_block = FirstBlock(KernelBuild.start(plan_.env))
    checkpoints = progress = None
    opened: list = []
    status = 0
    failure: str | None = None  # the error line, once the run directory is put in order
    kept = ""  # what the error line adds when the run keeps its checkpoints
    stopped_at_once = False  # by a second interrupt: nothing more is waited for
    callbacks: HostCallbacks | None = None
    try:
        with interrupts.attributed():
            checkpoints = checkpointer.Checkpointer(
                run_dir / layout.CHECKPOINT_DIR, keep=run.keep_checkpoints, create=True
            )
            progress = console.Progress.open(plan_, None) if primary else Silent()
            # Process 0 alone writes. Opened one by one: a failure closes those opened before it.
            for sink_type in sinks.registered() if primary else ():
                if (sink := sink_type.open(plan_, progress)) is not None:
                    opened.append(sink)
            if plan_.start == 0:
                for sink in opened:
                    sink.add_text("config", "```\n" + json.dumps(run.to_json(), indent=2) + "\n```")
            callbacks = host_callbacks(plan_, checkpoints, opened, progress, wall_offset, interrupts)
            block = run.block_size
            # Blocks start at multiples of block_size, as in an uninterrupted run.
            segments = []
            misaligned = (-plan_.start) % block
            if misaligned:
                segments.append(min(misaligned, remaining))
            if remaining - sum(segments) > 0:
                segments.append(remaining - sum(segments))
            # Nothing else is printed until the first block has compiled and run, which takes
            # minutes for a MuJoCo task on a CPU: say what the wait is.
            show(
                f"compiling: the first block of {min(block, segments[0])} iteration(s) compiles before its "
                "first metrics line (minutes for a MuJoCo task on a CPU)"
            )
            first_block.started = time.perf_counter()  # its compilation is timed from here
            for index, count in enumerate(segments):
                ts = train.train(
                    update,
                    ts,
                    count,
                    block_size=min(block, count),
                    callbacks=callbacks.callables,
                    seeds=run.vmap_seeds,
                    evaluate=evaluate,
                    final_eval=index == len(segments) - 1,  # the run's last iteration is always evaluated
                    before_first_call=first_block if index == 0 else None,
                )
    except Stop as stop:
        progress.close()
        print(
            f"{stop}: stopped after iteration {callbacks.last_iteration}, checkpoint {callbacks.last_saved} written. "
            f"Continue with: {resume_command(run_dir)}",
            file=sys.stderr,
        )
        status = exit_status(stop.signum)
    except KeyboardInterrupt:
        stopped_at_once = True
        if progress is not None:
            progress.close()
        saved = callbacks.last_saved if callbacks is not None else plan_.start
        note = stopped_at_once_note(plan_, checkpointed=saved > 0) if primary else ""
        signum = interrupts.requested or signal.SIGINT
        print(f"\n{signal.Signals(signum).name}: stopped at once{note}", file=sys.stderr)
        return exit_status(signum)
    except TimeUp:
        progress.close()
        show(
            f"time limit of {plan_.time_limit_s / 60:g} min reached after iteration {callbacks.last_iteration} "
            f"(checkpoint written; continue with: {resume_command(run_dir)})"
        )
    except train.TrainingDiverged as e:
        progress.close()
        failure, kept = str(e), f"; metrics and checkpoints up to then are in {run_dir}"
        status = 1
    except (OSError, checkpoint_errors.CheckpointError) as e:
        if progress is not None:
            progress.close()
        what = f"{e.strerror}: {e.filename}" if isinstance(e, OSError) and e.strerror else str(e).splitlines()[0]
        hint = " (disk full?)" if isinstance(e, OSError) and e.errno == 28 else ""
        failure, kept = f"writing the run directory failed: {what}{hint}", ""
        status = 2
    finally:
        for closable in (progress, *opened, checkpoints):
            if closable is not None:
                try:
                    closable.close()
                except Exception:  # noqa: BLE001 - closing after a failure must not hide it
                    pass
        if callbacks is not None:  # the curves' last drawing, in its helper process while the above closed
            try:
                warnings = callbacks.close(wait=not stopped_at_once)
            except KeyboardInterrupt:  # a second Ctrl-C while waiting for that drawing: stop waiting
                warnings = callbacks.close(wait=False)
            for warning in warnings:
                print(warning, file=sys.stderr)
    saved = callbacks.last_saved if callbacks is not None else plan_.start
    note = finish_run_dir(plan_, checkpointed=saved > 0) if primary else ""
    if failure is not None:
        # Without a checkpoint there is nothing to resume: the note says what is on disk instead.
        print(f"error: {_without_resume_advice(failure) + note if note else failure + kept}", file=sys.stderr)
    elif note:
        print(f"the run stopped before its first checkpoint{note}", file=sys.stderr)
    if status == 0 and primary:
        _report_end(plan_, callbacks.clock, first_block)
    processes.barrier("jaxpg: done")  # the processes leave together (JAX's shutdown waits for all)
    return status


def _without_resume_advice(message: str) -> str:
    """``message`` without a closing advice to continue with ``--resume``."""
    return re.sub(r"[,;]?\s*(then )?continue with --resume\b.*$", "", message)


class FirstBlock:
    """``train``'s ``before_first_call`` for the run's first block: notes when its program is
    compiled (or loaded from the compilation cache), waits for MuJoCo Warp's kernels
    (``KernelBuild``, built beside the compilation) and notes when they are ready, for the
    end-of-run report."""

    def __init__(self, kernels: KernelBuild) -> None:
        self.kernels = kernels
        self.started = time.perf_counter()
        self.compiled: float | None = None
        self.ready: float | None = None

    def __call__(self) -> None:
        self.compiled = time.perf_counter()
        self.kernels.wait()
        self.ready = time.perf_counter()

    def report(self) -> str | None:
        """``first block: compiled in X s[, then Y s waiting for MuJoCo Warp's kernels (...)]``, or
        ``None`` before the first block was compiled."""
        if self.compiled is None or self.ready is None:
            return None
        line = f"first block: compiled in {self.compiled - self.started:.1f} s"
        if self.kernels.modules and self.kernels.seconds is not None:
            line += (
                f", then {self.ready - self.compiled:.1f} s waiting for MuJoCo Warp's kernels "
                f"({self.kernels.modules} modules built in {self.kernels.seconds:.1f} s beside the compilation)"
            )
        return line


def _report_end(plan_: Plan, clock: BlockClock, first_block: FirstBlock | None = None) -> None:
    """The end-of-run report: speed, the first block's compilation, evaluation share, best
    checkpoint, how to evaluate."""
    run, run_dir = plan_.run, plan_.run_dir
    # The first block includes compilation.
    timed = clock.block_times[1:]
    iters = sum(n for n, _ in timed)
    secs = sum(t for _, t in timed)
    total = sum(t for _, t in clock.block_times)
    total += clock.eval_seconds
    host = sum(t for _, t in clock.host_times)
    if iters and secs > 0:
        rate = clock.samples * iters / secs
        show(f"done in {total:.1f} s: {secs / iters:.3f} s per iteration, {rate:,.0f} env steps/s after compilation")
    else:
        show(f"done in {total:.1f} s (including compilation)")
    if first_block is not None and (first := first_block.report()) is not None:
        show(first)
        if plan_.startup is not None and (started := plan_.startup.report(first_block.started)) is not None:
            show(started)
    if clock.evaluations:
        share = 100 * clock.eval_seconds / max(total, 1e-9)
        show(
            f"evaluation: {clock.evaluations} of the mean policy ({run.config.get('eval_envs')} episodes each), "
            f"{clock.eval_seconds:.1f} s ({share:.1f}% of the training loop's wall clock)"
        )
    if host >= 1.0:
        every = f" every {run.checkpoint_every} iterations" if run.checkpoint_every else ""
        show(
            f"host work between blocks: {host:.1f} s beside those {total:.1f} s (metrics.jsonl, TensorBoard, "
            f"checkpoints{every}, curves.png, videos)"
        )
    if plan_.profile and iters:
        seeds = f", {len(run.seeds)} seeds vmapped" if run.vmap_seeds else ""
        show(f"fused update (scan of {run.block_size} iterations{seeds}): {secs / iters * 1e3:.2f} ms per iteration")
    try:
        checkpoints = checkpointer.Checkpointer(run_dir / layout.CHECKPOINT_DIR, keep=None)
        # Both verified: a damaged step is skipped (with a warning line), never recommended.
        best, latest = checkpoints.resolve_step("best"), checkpoints.resolve_step("latest")
        if best is not None and best != latest:
            score = checkpoints.score(best)
            show(f"best checkpoint: iteration {best} (return {score:.1f}); evaluate it with --step best")
        checkpoints.close()
    except ValueError:
        pass
    show(f"run directory: {run_dir}  (metrics.jsonl, curves.png, tensorboard/, checkpoints/)")
    if run.task == "atari_pong":  # the real game is ALE's: play it there
        show(f"evaluate: python -m jaxpg.evaluate {shlex.quote(str(run_dir))} --ale --episodes 10 [--no-sticky]")
        return
    gymnasium = " [--gymnasium]" if replay.gymnasium_counterpart(run.task) else ""
    quoted = shlex.quote(str(run_dir))
    video = f"[--video {shlex.quote(str(run_dir / layout.VIDEO_DIR / 'final.mp4'))}]"
    show(f"evaluate: python -m jaxpg.evaluate {quoted} --episodes 10{gymnasium} {video}")
