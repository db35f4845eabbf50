"""The host's work between compiled training calls, as small callables handed to
``jaxpg.train.train(callbacks=[...])`` (as Brax hands its loop ``progress_fn``).

Each callable is ``callback(train_state, metrics, first_iteration)`` and does one job; they run in
the order ``host_callbacks`` lists them, after every block of iterations:

  ``guard_interrupts``  an interrupt that asked to stop at once stops here, before anything of the
                        block is written; from the first block on, interrupts checkpoint first;
  ``BlockClock.start_block``  the block's duration, wall times and training rate (evaluation,
                        which ran between the block's calls, left out);
  ``write_sinks``       the block to the run's sinks (``jaxpg.run.outputs.sink``): ``metrics.jsonl``,
                        TensorBoard, the curves' history, any registered sink, the progress bar;
  ``Summaries``         the summary line every ``log_every`` iterations, with its ETA, and the
                        warnings about rolled-back updates and physics overflows;
  ``guard_divergence``  a diverged block (``jaxpg.run.training.divergence``) stops the run before
                        anything of it is checkpointed;
  ``Checkpoints``       a checkpoint every ``checkpoint_every`` iterations and at the end, and
                        ``curves.png`` (redrawn at most every ``PLOT_EVERY_S`` seconds from the
                        start, and at the end, by a helper process while the checkpoint is
                        written: ``plot_process``);
  ``write_sinks``       the block to the sinks that come after its checkpoint: videos of the
                        mean policy every ``video_every`` iterations and at the end
                        (``jaxpg.run.outputs.videos``);
  ``TimeLimit``         past ``--minutes``: checkpoint, then ``TimeUp``;
  ``StopOnRequest``     after SIGINT / SIGTERM: checkpoint, then ``Stop``;
  ``BlockClock.end_host_work``  the host's own work is left out of the next block's rate.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from jaxpg.run.command.plan import Plan
from jaxpg.run.outputs import console, metrics_log, plotting
from jaxpg.run.outputs.metrics_log import block_length
from jaxpg.run.outputs.output import is_primary
from jaxpg.run.outputs.plot_process import CurvePainter
from jaxpg.run.outputs.sink import Block, Sink
from jaxpg.run.rundir.interrupts import Stop, StopAtOnce, TimeUp
from jaxpg.run.training.divergence import guard_divergence

Callback = Callable[[Any, dict[str, np.ndarray], int], None]
"""``callback(train_state, metrics, first_iteration)``, as ``jaxpg.train.train`` calls it."""


def guard_interrupts(interrupts: Any) -> Callback:
    """The first callback: a stop at once that was swallowed (raised inside a garbage-collection
    callback, which Python ignores) takes effect here; once a call has finished, interrupts
    checkpoint before they stop (``Interrupts.graceful``)."""

    def guard(ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        if interrupts.at_once:
            raise StopAtOnce
        interrupts.graceful = True

    return guard


class BlockClock:
    """The times of a run's blocks: what the metrics, the progress bar, the summaries, the ETA,
    the time limit and the end-of-run report read.

    Attributes:
      block_times: ``(iterations, training seconds)`` of every block so far.
      host_times: ``(iterations, seconds)`` of the host's work after every block so far (metrics,
        checkpoints, plots, videos), which the training rate leaves out and the ETA counts.
      eval_seconds, evaluations: the evaluations of the mean policy, which ran between calls.
      samples: env steps of one iteration, all seeds.
      last_iteration: the last iteration of the latest block.
      wall_times, steps_per_s, train_s: of the latest block.
    """

    def __init__(self, plan_: Plan, wall_offset: float):
        self.plan = plan_
        self.wall_offset = wall_offset
        self.t_start = self.t_last = time.perf_counter()
        self.samples = plan_.config.samples_per_iteration * len(plan_.run.seeds)
        self.block_times: list[tuple[int, float]] = []
        self.host_times: list[tuple[int, float]] = []
        self.eval_seconds = 0.0
        self.evaluations = 0
        self.last_iteration = plan_.start
        self.clock_start: float | None = None  # end of the first block: the time limit counts from here
        self.wall_times: list[float] = []
        self.steps_per_s = 0.0
        self.train_s = 0.0

    def start_block(self, ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        """Time the block that just ended."""
        now = time.perf_counter()
        duration = now - self.t_last
        n = block_length(metrics)
        self.wall_times = [self.wall_offset + (self.t_last + duration * (i + 1) / n - self.t_start) for i in range(n)]
        self.t_last = now
        # Evaluation ran between this block's training calls: keep it out of the training rate.
        eval_s = float(np.max(np.sum(metrics["eval_seconds"], axis=0))) if "eval_seconds" in metrics else 0.0
        self.eval_seconds += eval_s
        self.evaluations += int(np.max(np.sum(metrics.get("evaluated", np.zeros(1)), axis=0)))
        self.train_s = max(duration - eval_s, 1e-9)
        self.block_times.append((n, self.train_s))
        self.steps_per_s = self.samples * n / self.train_s
        self.last_iteration = first + n

    def end_host_work(self, ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        """The last callback: host work (checkpoints, plots, videos) is left out of the next
        block's throughput, and counted on its own."""
        now = time.perf_counter()
        self.host_times.append((block_length(metrics), now - self.t_last))
        self.t_last = now

    def out_of_time(self, now: float) -> bool:
        """``plan.time_limit_s`` has passed since the end of the first block (which compiles, so
        that the limit counts training alone); never before a second block has run."""
        if self.plan.time_limit_s is None:
            return False
        if self.clock_start is None:
            self.clock_start = now
            return False
        return now - self.clock_start >= self.plan.time_limit_s

    def eta(self, last: int) -> float | None:
        """Seconds left at the rate measured after the first block (which compiles): training and
        the host's work between blocks, plus the evaluations still due at their measured cost, or
        the time limit's remainder when that comes first (``--minutes``); ``None`` until a block
        after the first."""
        iterations = sum(n for n, _ in self.block_times[1:])
        if not iterations:
            return None
        per_iteration = sum(t for _, t in self.block_times[1:]) / iterations
        host_iterations = sum(n for n, _ in self.host_times[1:])
        if host_iterations:
            per_iteration += sum(t for _, t in self.host_times[1:]) / host_iterations
        config = self.plan.config
        left = self.plan.run.iterations - last
        per_eval = self.eval_seconds / self.evaluations if self.evaluations else 0.0
        every = int(config.eval_every) if getattr(config, "eval_envs", 0) else 0
        evals_left = (left // every if every else 0) + (1 if every else 0)
        eta = left * per_iteration + evals_left * per_eval
        if self.plan.time_limit_s is not None and self.clock_start is not None:
            eta = min(eta, max(0.0, self.plan.time_limit_s - (time.perf_counter() - self.clock_start)))
        return eta


def write_sinks(sinks: list[Sink], clock: BlockClock, seeds: list[int]) -> Callback:
    """Hand each block to ``sinks``, in order: its records (with the clock's wall times, made once
    for all of them) and its training rate."""

    def write(ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        if not sinks:
            return
        records = metrics_log.block_records(metrics, first, seeds, clock.wall_times)
        block = Block(ts, metrics, first, records, clock.steps_per_s)
        for sink in sinks:
            sink.write_block(block)

    return write


class Summaries:
    """The summary line every ``log_every`` iterations (and at the end), over the blocks since the
    last one, and one-line warnings: updates rolled back, TRPO steps refused, physics overflows."""

    def __init__(self, plan_: Plan, clock: BlockClock, progress: console.Progress):
        self.plan, self.clock, self.progress = plan_, clock, progress
        self.pending: list[dict[str, np.ndarray]] = []
        self.pending_steps = 0
        self.pending_time = 0.0
        self.first_block = True
        self.overflow_noted = False

    def __call__(self, ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        run = self.plan.run
        n = block_length(metrics)
        last = first + n
        self.pending.append(metrics)
        self.pending_steps += self.clock.samples * n
        self.pending_time += self.clock.train_s
        self._note_overflow(metrics, first)
        if last % run.log_every == 0 or last >= run.iterations:
            merged = {k: np.concatenate([m[k] for m in self.pending]) for k in self.pending[0]}
            rate = self.pending_steps / max(self.pending_time, 1e-9)
            note = " (incl. compile)" if self.first_block else ""
            line = console.summary_line(merged, last, run.iterations, rate, note, self.clock.eta(last))
            self.progress.write(line)
            self._note_rejections(merged, last - block_length(merged))
            self.pending, self.pending_steps, self.pending_time = [], 0, 0.0
            self.first_block = False

    def _note_rejections(self, metrics: dict[str, np.ndarray], first: int) -> None:
        """One line per block in which updates were rolled back (trust region or non-finite) or
        TRPO's line search accepted no step, so that a policy that stops moving says why."""
        n = block_length(metrics)
        if "line_search_accepted" in metrics:
            no_step = np.asarray(metrics["line_search_accepted"]).reshape(n, -1).min(axis=1) == 0
            if no_step.any():
                self.progress.write(
                    f"warning: TRPO's line search accepted no step in {int(no_step.sum())} of iterations "
                    f"{first + 1}-{first + n} (the policy did not move; is max_kl {self.plan.config.max_kl} too large "
                    "or too small?)"
                )
        config = self.plan.config
        if all(k in metrics for k in ("update_rejected", "kl", "consecutive_failures")):
            limit, normalized = getattr(config, "max_update_kl", 0), getattr(config, "normalize_observations", False)
            line = console.rejection_line(metrics, first, limit, normalized)
            if line is not None:
                self.progress.write(line)

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
                f"{self.clock.samples:,} env steps of iteration {first + row + 1} (MuJoCo Warp overflow flags; "
                "counted per iteration in metrics.jsonl as physics_overflow, not reported again)"
            )


PLOT_EVERY_S = 30.0
"""Seconds between redraws of ``curves.png`` at periodic checkpoints, counted from the start of
training: drawing thousands of iterations of many seeds takes a large part of a second, which a
run whose blocks take a fraction of a second would otherwise pay at every checkpoint; and a run
shorter than this draws its curves once, at the end (the first drawing, with matplotlib's import,
costs most, a later one less)."""


@dataclasses.dataclass
class Checkpoints:
    """A checkpoint every ``checkpoint_every`` iterations and at the end (every process: the save
    gathers the state; process 0 writes), then ``curves.png`` from ``history`` (at most every
    ``PLOT_EVERY_S`` seconds, the first time ``PLOT_EVERY_S`` after the start; always at the
    end); ``save_now`` for the time limit and interrupts. ``last_saved``: the iteration of the
    latest checkpoint; ``last_plot``: when ``curves.png`` was last drawn (at first: when the run's
    callbacks were made, before its first block)."""

    plan: Plan
    checkpoints: Any
    progress: Any
    history: plotting.CurveHistory | None = None
    last_saved: int = 0
    primary: bool = dataclasses.field(default_factory=is_primary)
    last_plot: float = dataclasses.field(default_factory=lambda: time.perf_counter())
    plotted: int = -1
    painter: CurvePainter = dataclasses.field(default_factory=CurvePainter)

    def __call__(self, ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        run, last = self.plan.run, first + block_length(metrics)
        if (run.checkpoint_every and last % run.checkpoint_every == 0) or last >= run.iterations:
            self.save_now(ts, last, metrics, final=last >= run.iterations)

    def save_now(self, ts: Any, step: int, metrics: dict[str, np.ndarray], final: bool = True) -> None:
        """Checkpoint ``ts`` as ``step`` (scored by ``metrics``), then redraw the curves (when
        ``final``, or ``PLOT_EVERY_S`` after the last redraw)."""
        run = self.plan.run
        last_metrics = {
            k: float(np.nanmean(v[-1])) if not np.all(np.isnan(v[-1])) else None for k, v in metrics.items()
        }
        draw = self.primary and (final or time.perf_counter() - self.last_plot >= PLOT_EVERY_S)
        beside = draw and self.painter.process is not None  # the helper draws while the checkpoint is written
        if beside:
            self.plot(step, final)
        self.checkpoints.save(
            step,
            ts,
            score=metrics_log.checkpoint_score(metrics, evaluated=getattr(self.plan.config, "eval_envs", 0) > 0),
            metrics=last_metrics,
            info={"task": run.task, "algo": run.algo, "seeds": run.seeds},
        )
        self.last_saved = step
        if draw and not beside:
            self.plot(step, final)

    def save_if_behind(self, ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        """Checkpoint the block's last iteration unless that is the latest checkpoint already, and
        make sure ``curves.png`` shows it."""
        last = first + block_length(metrics)
        if self.last_saved != last:
            self.save_now(ts, last, metrics)
        elif self.primary and self.plotted != last:
            self.plot(last)

    def plot(self, step: int, final: bool = True) -> None:
        """Redraw ``curves.png`` through iteration ``step`` (through the painter: a periodic drawing
        is skipped while its helper process still draws the last one); a failure is a warning line
        (a plot must never stop training)."""
        asked, warnings = self.painter.draw(self.plan.run_dir, self.history, self.plan.env.task_score_name, final)
        if asked:
            self.last_plot, self.plotted = time.perf_counter(), step
        for warning in warnings:
            self.progress.write(warning)


def time_limit(clock: BlockClock, checkpoints: Checkpoints) -> Callback:
    """Past the plan's time limit (counted from the end of the first block), before the run's
    end: checkpoint, then ``TimeUp``."""

    def check(ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        if clock.out_of_time(time.perf_counter()) and first + block_length(metrics) < clock.plan.run.iterations:
            checkpoints.save_if_behind(ts, metrics, first)
            raise TimeUp

    return check


def stop_on_request(interrupts: Any, checkpoints: Checkpoints) -> Callback:
    """After SIGINT / SIGTERM (``interrupts.requested``): checkpoint, then ``Stop``."""

    def check(ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        if interrupts.requested is not None:
            checkpoints.save_if_behind(ts, metrics, first)
            raise Stop(interrupts.requested)

    return check


@dataclasses.dataclass
class HostCallbacks:
    """A run's callbacks (``callables``, in order) and the two that the session reads after
    training stops: the clock (iterations done, timings) and the checkpoints (the latest saved)."""

    callables: list[Callback]
    clock: BlockClock
    checkpoints: Checkpoints

    @property
    def last_iteration(self) -> int:
        return self.clock.last_iteration

    @property
    def last_saved(self) -> int:
        return self.checkpoints.last_saved

    def close(self, wait: bool = True) -> list[str]:
        """Let the curves' last drawing finish (unless ``wait`` is False); its warning lines."""
        return self.checkpoints.painter.close(wait)


def host_callbacks(
    plan_: Plan,
    checkpoints: Any,
    sinks: list[Sink],
    progress: console.Progress,
    wall_offset: float,
    interrupts: Any,
) -> HostCallbacks:
    """The callbacks of a run, in the order they must run (module docstring). ``sinks``: the run's
    opened sinks (``jaxpg.run.outputs.sinks.registered``, process 0 alone); ``progress``, the console's, comes last of
    those before the checkpoint."""
    clock = BlockClock(plan_, wall_offset)
    # The curves of a resumed run start from its metrics.jsonl (plotting.CurveHistory.open).
    history = next((s for s in sinks if isinstance(s, plotting.CurveHistory)), plotting.CurveHistory())
    before = [s for s in sinks if not s.after_checkpoint] + [progress]
    after = [s for s in sinks if s.after_checkpoint]
    # curves.png is drawn by a helper process (plot_process), started now: matplotlib is ready by the first drawing.
    painter = CurvePainter.start() if is_primary() else CurvePainter()
    saving = Checkpoints(plan_, checkpoints, progress, history=history, last_saved=plan_.start, painter=painter)
    callables: list[Callback] = [
        guard_interrupts(interrupts),
        clock.start_block,
        write_sinks(before, clock, plan_.run.seeds),
        Summaries(plan_, clock, progress),
        guard_divergence(plan_, saving),
        saving,
        write_sinks(after, clock, plan_.run.seeds),
        time_limit(clock, saving),
        stop_on_request(interrupts, saving),
        clock.end_host_work,
    ]
    return HostCallbacks(callables, clock, saving)
