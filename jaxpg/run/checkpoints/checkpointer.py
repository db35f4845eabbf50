"""Writing checkpoints: save, read the policy back, checksum, keep the latest and the best.

Saving: after writing a step the policy item is read back and compared with what was saved; a
step that does not read back is removed. Disk-full, permission and read-only-file-system errors
become one-line ``CheckpointError``s saying what to do. Every ``CheckpointError`` is one line.

Retention: the ``keep`` latest steps plus the best one (highest ``score``, which the caller
computes, e.g. ``jaxpg.run.outputs.metrics_log.checkpoint_score``); the newest step is always kept, whatever
``keep`` is, so that the final checkpoint of a run survives.

Several processes (``jaxpg.run.host.processes``): every process calls ``save``, which gathers the
state to the host (a collective: arrays split over processes are all-gathered); process 0 alone
writes. Every process restores, each reading the files itself (a shared file system across
hosts), onto its own first device; ``jaxpg.algos.core.shard_state`` then places the state on the
global mesh. Each process's Orbax manager works alone (no barriers across processes).
"""

from __future__ import annotations

import contextlib
import errno
import math
import shutil
from typing import Any

import jax
import numpy as np

from jaxpg import mesh as mesh_lib
from jaxpg.run.checkpoints.checkpoint_errors import (
    ERRNO_TEXT,
    CheckpointError,
    Damaged,
    first_line,
    os_errno,
    quiet_orbax,
    save_advice,
)
from jaxpg.run.checkpoints.checkpoint_format import (
    CHECKSUMS_KEY,
    META,
    POLICY,
    SPECS_KEY,
    STATE,
    is_committed,
    leaf_key,
    leaf_specs,
    policy_part,
    write_manifest,
)
from jaxpg.run.checkpoints.checkpoint_reader import CheckpointReader


class Checkpointer(CheckpointReader):
    """Saves ``TrainState``s under ``directory`` (a run's ``checkpoints/``), checks that each reads
    back, applies the retention policy; restores them as ``CheckpointReader`` does.
    """

    def save(
        self,
        step: int,
        train_state: Any,
        score: float = -math.inf,
        metrics: dict[str, float] | None = None,
        info: dict[str, Any] | None = None,
    ) -> None:
        """Save ``train_state`` as ``step`` (synchronously), check that its policy reads back,
        then apply the retention policy.

        ``score`` ranks checkpoints for "best"; ``metrics`` and ``info`` (task, algorithm ...)
        go to ``meta``. Arrays are copied to the host first, so the caller may donate
        ``train_state``'s buffers right after. With several processes every process calls
        ``save`` (the copy gathers arrays split over processes) and process 0 alone writes.
        Raises ``CheckpointError`` (one line: what happened, what to do) when the disk is full,
        the directory is not writable or the step does not read back (it is then removed).
        """
        train_state = mesh_lib.host_copy(train_state)
        if not self.writer:
            return
        step = int(step)
        policy = policy_part(train_state)
        policy_leaves = [np.asarray(x) for x in jax.tree.leaves(policy)]
        score = float(score) if score is not None and math.isfinite(float(score)) else -math.inf
        meta = {
            "step": step,
            "score": score if math.isfinite(score) else None,
            "metrics": {
                k: (float(v) if v is not None and math.isfinite(float(v)) else None) for k, v in (metrics or {}).items()
            },
            **(info or {}),
            CHECKSUMS_KEY: "sha256",
            "state_leaves": leaf_specs(train_state),
            "policy_leaves": leaf_specs(policy),
        }
        # Orbax cannot write zero-size arrays (MJX has empty contact arrays in contact-free
        # models); they are rebuilt from the leaf specs on restore.
        state_items = {leaf_key(i): np.asarray(x) for i, x in enumerate(jax.tree.leaves(train_state))}
        state_items = {k: x for k, x in state_items.items() if x.size}
        policy_items = {leaf_key(i): x for i, x in enumerate(policy_leaves) if x.size}
        try:
            self._write(step, state_items, policy_items, meta)
        except Exception as e:  # noqa: BLE001 - every failure of a write is one line
            self._remove_step(step)
            found = os_errno(e)
            if found is None:
                raise CheckpointError(
                    f"cannot save checkpoint {step} in {self.directory} ({first_line(e, self.directory)})"
                ) from None
            code, filename = found
            where = f" ({filename})" if filename else ""
            raise CheckpointError(
                f"cannot save checkpoint {step} in {self.directory}{where}: {save_advice(code)}"
            ) from None
        self._check_saved_policy(step, policy_items, meta[SPECS_KEY[POLICY]])
        try:
            write_manifest(self.directory / str(step))
        except OSError as e:
            self._remove_step(step)
            code = e.errno if e.errno in ERRNO_TEXT else None
            advice = save_advice(code) if code is not None else first_line(e, self.directory)
            raise CheckpointError(
                f"cannot save the checksums of checkpoint {step} in {self.directory}: {advice}"
            ) from None
        self._scores[step] = score
        self._apply_retention()

    def _write(self, step: int, state_items: dict, policy_items: dict, meta: dict[str, Any]) -> None:
        """Write ``step`` through Orbax, replacing a step directory of that number (damaged or
        uncommitted) and clearing what was cached about it."""
        ocp = self._ocp
        self._forget(step)
        if step in self.steps():
            self.manager.delete(step)
        elif (self.directory / str(step)).exists():
            shutil.rmtree(self.directory / str(step))
            self.manager.reload()
        with quiet_orbax():
            self.manager.save(
                step,
                args=ocp.args.Composite(
                    **{
                        STATE: ocp.args.StandardSave(state_items),
                        POLICY: ocp.args.StandardSave(policy_items),
                        META: ocp.args.JsonSave(meta),
                    }
                ),
                force=True,
            )
            self.manager.wait_until_finished()

    def _check_saved_policy(self, step: int, saved: dict[str, np.ndarray], specs: list[dict[str, Any]]) -> None:
        """Read the policy item of the step just written back and compare it with ``saved``;
        remove the step and raise ``CheckpointError`` when it is not committed or differs."""
        try:
            if not is_committed(self.directory / str(step)):
                raise Damaged("it has no commit marker")
            back = self._read_arrays(step, POLICY, specs)
            for key, x in saved.items():
                if not np.array_equal(back[key], x, equal_nan=x.dtype.kind in "fc"):
                    raise Damaged(f"array {specs[int(key)]['path']} differs from what was saved")
        except Damaged as e:
            self._remove_step(step)
            raise CheckpointError(
                f"checkpoint {step} in {self.directory} did not read back after saving ({e}) and was removed; "
                "check the disk (free space, errors), then continue with --resume"
            ) from None

    def _remove_step(self, step: int) -> None:
        """Delete what a failed save of ``step`` left: its step directory and temporary ones."""
        self._forget(step)
        for path in [self.directory / str(step), *self.directory.glob(f"{step}.orbax-checkpoint-tmp*")]:
            shutil.rmtree(path, ignore_errors=True)
        with contextlib.suppress(Exception):
            self.manager.reload()

    def _apply_retention(self) -> None:
        if self.keep is None:
            return
        steps = self.steps()
        keep = set(steps[-max(self.keep, 1) :])  # the newest step always survives (a run's final checkpoint)
        best = self.best_step()
        if best is not None:
            keep.add(best)
        for step in steps:
            if step not in keep:
                try:
                    self.manager.delete(step)
                except OSError as e:
                    code = e.errno if e.errno in ERRNO_TEXT else errno.EACCES
                    raise CheckpointError(
                        f"cannot delete old checkpoint {step} in {self.directory}: {save_advice(code)}"
                    ) from None
                self._forget(step)
