"""The host's work between compiled training calls: metrics, progress, checkpoints, curves, videos."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from jaxpg.run import console, layout, metrics_log
from jaxpg.run.interrupts import Stop, StopAtOnce, TimeUp
from jaxpg.run.output import is_primary, seed_slice
from jaxpg.run.plan import Plan


class Callbacks:
    """Host side of training: metrics, progress, summaries, checkpoints, videos, curves."""

    def __init__(
        self,
        plan_: Plan,
        checkpoints: Any,
        writer: metrics_log.MetricsWriter,
        progress: console.Progress,
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
        self.primary = is_primary()
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
            raise StopAtOnce
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
        self.writer.write(metrics_log.block_records(metrics, first, self.run.seeds, wall_times))
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
            line = console.summary_line(merged, last, self.run.iterations, rate, note, self.eta(last))
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
            raise TimeUp
        if self.interrupts is not None and self.interrupts.requested is not None:
            if self.last_saved != last:
                self.save(ts, last, metrics)
                if self.primary:
                    self.plot()
            raise Stop(self.interrupts.requested)
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
            score=metrics_log.checkpoint_score(metrics, evaluated=getattr(self.plan.config, "eval_envs", 0) > 0),
            metrics=last_metrics,
            info={"task": self.run.task, "algo": self.run.algo, "seeds": self.run.seeds},
        )
        self.last_saved = step

    def plot(self) -> None:
        try:
            from jaxpg.run import plotting

            plotting.plot_run(self.plan.run_dir, task_score_name=self.plan.env.task_score_name)
        except Exception as e:  # noqa: BLE001 - a plot must never stop training
            self.progress.write(f"warning: curves.png not updated ({type(e).__name__}: {e})")

    def video(self, ts: Any, step: int) -> None:
        from jaxpg import mesh as mesh_lib
        from jaxpg.run import policy_episodes

        path = self.plan.run_dir / layout.VIDEO_DIR / f"iter_{step:06d}.mp4"
        try:
            # Host copies: the video is recorded by process 0 alone, off the training mesh.
            params = seed_slice(mesh_lib.host_copy(ts.params), 0, self.run.vmap_seeds)
            stats = seed_slice(mesh_lib.host_copy(ts.obs_stats), 0, self.run.vmap_seeds)
            out, ret, length = policy_episodes.record_policy(self.plan.env, ts.policy, params, stats, path, seed=step)
            self.progress.write(
                f"video {out} (mean policy, seed {self.run.seeds[0]}: return {ret:.1f}, {length} steps)"
            )
        except Exception as e:  # noqa: BLE001 - videos are optional: warn once, go on training
            self.videos_enabled = False
            self.progress.write(f"warning: videos disabled: {type(e).__name__}: {e}")
