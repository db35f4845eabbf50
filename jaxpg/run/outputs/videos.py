"""The run's videos: ``Videos``, the host callback (``jaxpg.run.training.callbacks``) that records the mean
policy every ``video_every`` iterations and at the end."""

from __future__ import annotations

from typing import Any

import numpy as np

from jaxpg import mesh as mesh_lib
from jaxpg.run.command.plan import Plan
from jaxpg.run.evaluation import policy_episodes
from jaxpg.run.outputs.metrics_log import block_length
from jaxpg.run.outputs.output import is_primary, seed_slice
from jaxpg.run.outputs.sink import Block, Entry, Sink
from jaxpg.run.rundir import layout


class Videos(Sink):
    """The sink of videos: one of the mean policy (the first seed's) every ``video_every``
    iterations and at the end (after that block's checkpoint), by process 0; the first failure
    disables videos with one warning line."""

    entries = (Entry(layout.VIDEO_DIR, directory=True, inside=(rf"{layout.VIDEO_DIR}/[^/]+\.(mp4|gif)",)),)
    after_checkpoint = True

    @classmethod
    def open(cls, plan: Plan, printer: Any) -> Videos | None:
        """Only for a run with ``--video-every``."""
        return cls(plan, printer) if plan.run.video_every > 0 else None

    def write_block(self, block: Block) -> None:
        self(block.state, block.metrics, block.first)

    def __init__(self, plan_: Plan, progress: Any):
        self.plan, self.progress = plan_, progress
        self.enabled = plan_.run.video_every > 0 and is_primary()

    def __call__(self, ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        run, last = self.plan.run, first + block_length(metrics)
        if self.enabled and (last % run.video_every == 0 or last >= run.iterations):
            self.record(ts, last)

    def record(self, ts: Any, step: int) -> None:
        run = self.plan.run
        path = self.plan.run_dir / layout.VIDEO_DIR / f"iter_{step:06d}.mp4"
        try:
            # Host copies: the video is recorded by process 0 alone, off the training mesh.
            params = seed_slice(mesh_lib.host_copy(ts.params), 0, run.vmap_seeds)
            stats = seed_slice(mesh_lib.host_copy(ts.obs_stats), 0, run.vmap_seeds)
            clipped_mean = ts.config.eval_action == "clipped_mean"
            out, ret, length = policy_episodes.record_policy(
                self.plan.env, ts.policy, params, stats, path, seed=step, clipped_mean=clipped_mean
            )
            self.progress.write(f"video {out} (mean policy, seed {run.seeds[0]}: return {ret:.1f}, {length} steps)")
        except Exception as e:  # noqa: BLE001 - videos are optional: warn once, go on training
            self.enabled = False
            self.progress.write(f"warning: videos disabled: {type(e).__name__}: {e}")
