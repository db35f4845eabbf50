"""Reading checkpoints back, every step checked whole before it counts.

Damage: every read of a step's arrays checks the whole step: its items are present, its ``meta``
parses, every array of ``state`` and ``policy`` reads, then every file matches its checksum
(flipped bytes that still parse are caught here). ``"latest"`` and ``"best"`` (and
``latest_step``) mean the newest (best) checkpoint that passes; a damaged step is skipped with one
``warning:`` line on stderr naming it and why; nothing on disk is changed. A step asked for by
number is not replaced by another: it is restored if it passes, else one ``CheckpointError``.
The arrays read while checking a step are kept until it is restored, so that a restore right
after ``latest_step`` reads the files once.

Several processes: every process restores, each reading the files itself (a shared file system
across hosts), onto its own first device; ``jaxpg.algos.core.shard_state`` then places the state
on the global mesh. Each process's Orbax manager works alone (no barriers across processes).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from typing import Any

import jax
import numpy as np

from jaxpg.run.checkpoints.checkpoint_errors import (
    CheckpointError,
    Damaged,
    first_line,
    os_errno,
    quiet_orbax,
    save_advice,
)
from jaxpg.run.checkpoints.checkpoint_format import (
    CHECKSUMS_KEY,
    ITEMS,
    MANIFEST,
    META,
    POLICY,
    SPECS_KEY,
    STATE,
    abstract_items,
    check_specs,
    is_committed,
    leaf_key,
    leaf_specs,
    manifest_problem,
)
from jaxpg.run.host import processes


class CheckpointReader:
    """Reads the ``TrainState``s saved under ``directory`` (a run's ``checkpoints/``), skipping damaged
    steps; ``Checkpointer`` writes them.

    Args:
      directory: the checkpoint directory.
      keep: how many of the latest steps to keep (the best step is kept as well); ``None``
        keeps all.
      create: create ``directory`` if missing (for writing); readers leave it ``False`` so that
        a missing directory is an error and nothing is created.
    """

    def __init__(self, directory: str | os.PathLike, keep: int | None = 3, create: bool = False):
        # Here, not at the top: Orbax (with TensorStore) is slow to import, which --help
        # and a command refused before it touches a checkpoint need not pay.
        import orbax.checkpoint as ocp

        self.directory = Path(directory).absolute()
        self.keep = keep
        self.writer = processes.is_primary()
        if not create and not self.directory.is_dir():
            if self.directory.exists():
                raise CheckpointError(f"no checkpoints: {self.directory} is a file, not a directory")
            raise CheckpointError(f"no checkpoints: {self.directory} does not exist")
        self._ocp = ocp
        multiprocessing: dict[str, Any] = {}
        try:
            if jax.process_count() > 1:
                # Each process's manager on its own: process 0 writes, every process reads for itself.
                me = jax.process_index()
                multiprocessing["multiprocessing_options"] = ocp.options.MultiprocessingOptions(
                    primary_host=me, active_processes={me}, barrier_sync_key_prefix=f"jaxpg-process-{me}"
                )
                if create and self.writer:  # Orbax leaves that to us when it works per process
                    self.directory.mkdir(parents=True, exist_ok=True)
            options = ocp.CheckpointManagerOptions(
                max_to_keep=None,
                create=create and self.writer and not multiprocessing,
                enable_async_checkpointing=False,
                cleanup_tmp_directories=False,
                **multiprocessing,
            )
            self.manager = ocp.CheckpointManager(self.directory, options=options)
        except Exception as e:  # noqa: BLE001 - a directory that cannot be made or read
            found = os_errno(e)
            if found is None:
                raise CheckpointError(f"cannot open checkpoint directory {self.directory} ({first_line(e)})") from None
            raise CheckpointError(
                f"cannot create checkpoint directory {self.directory}: {save_advice(found[0])}"
            ) from None
        self._scores: dict[int, float] = {}
        self._damage: dict[int, str | None] = {}  # step -> why it does not read back (None: it does)
        self._read: dict[int, dict[str, Any]] = {}  # arrays and meta read while checking a step
        self._noted_unverified = False  # the note about steps without a checksum manifest was printed

    def steps(self) -> list[int]:
        """Committed checkpoint steps, ascending: temporary directories of unfinished writes and
        step directories without Orbax's commit marker are not steps (damaged ones are)."""
        self.manager.reload()
        return sorted(int(s) for s in self.manager.all_steps() if is_committed(self.directory / str(s)))

    def latest_step(self) -> int | None:
        """The newest step that reads back completely (``None`` when there are no checkpoints);
        damaged newer steps are skipped with a warning line. ``CheckpointError`` when there are
        checkpoints but none reads back."""
        steps = self.steps()
        return self._first_readable(steps[::-1]) if steps else None

    def read_meta(self, step: int) -> dict[str, Any]:
        """The ``meta`` item of ``step``; ``CheckpointError`` (one line) if it cannot be read."""
        try:
            return self._meta(step)
        except Damaged as e:
            raise CheckpointError(f"checkpoint step {step} in {self.directory} is unreadable ({e})") from None

    def score(self, step: int) -> float:
        """The saved score of ``step``; ``-inf`` for none, NaN or an unreadable ``meta``."""
        if step not in self._scores:
            try:
                value = self.read_meta(step).get("score")
            except CheckpointError:
                value = None
            try:
                number = -math.inf if value is None else float(value)
            except (TypeError, ValueError):
                number = -math.inf
            self._scores[step] = number if not math.isnan(number) else -math.inf
        return self._scores[step]

    def best_step(self) -> int | None:
        """The step with the highest saved score (the latest among equals); ``None`` when there
        are no checkpoints. Only the scores are read: ``resolve_step("best")`` checks the data."""
        steps = self.steps()
        if not steps:
            return None
        return max(steps, key=lambda s: (self.score(s), s))

    def resolve_step(self, step: int | str | None) -> int:
        """``None``/``"latest"``, ``"best"`` or a step number -> an existing step.

        ``"latest"`` and ``"best"`` give the newest (best) step that reads back completely,
        skipping damaged ones with a warning line on stderr; a number must be a committed step.
        """
        steps = self.steps()
        if not steps:
            raise CheckpointError(f"no checkpoint in {self.directory}")
        if step is None or step == "latest":
            return self._first_readable(steps[::-1])
        if step == "best":
            return self._first_readable(sorted(steps, key=lambda s: (self.score(s), s), reverse=True))
        try:
            step = int(step)
        except (TypeError, ValueError):
            raise CheckpointError(f"checkpoint step must be a number, 'latest' or 'best', got {step!r}") from None
        if step not in steps:
            raise CheckpointError(f"no checkpoint of step {step} in {self.directory}; steps: {steps}")
        return step

    def damage(self, step: int) -> str | None:
        """Why ``step`` does not read back completely (one short line), or ``None`` if it does.

        Reads the whole step: its ``meta`` and every array of ``state`` and ``policy``, then checks
        every file against the step's checksum manifest."""
        if step not in self._damage:
            try:
                self._read = {step: self._read_step(step)}  # kept for the restore that follows
                self._damage[step] = None
            except Damaged as e:
                self._damage[step] = str(e)
        return self._damage[step]

    def _first_readable(self, candidates: list[int]) -> int:
        """The first of ``candidates`` that reads back; one warning line per damaged step before
        it, or ``CheckpointError`` when none reads back."""
        skipped: list[tuple[int, str]] = []
        for step in candidates:
            reason = self.damage(step)
            if reason is None:
                for bad, why in skipped:
                    print(f"warning: checkpoint {bad} is damaged ({why}); using checkpoint {step}", file=sys.stderr)
                return step
            skipped.append((step, reason))
        bad, why = skipped[0]
        others = f" and {len(skipped) - 1} older one(s)" if len(skipped) > 1 else ""
        raise CheckpointError(
            f"no checkpoint in {self.directory} reads back completely (checkpoint {bad}{others} damaged: {why}); "
            "train the run again (a new --run-dir, or --overwrite to replace this one)"
        )

    def _meta(self, step: int) -> dict[str, Any]:
        """``meta`` of ``step`` (``Damaged`` if missing or unreadable)."""
        if step in self._read:
            return self._read[step][META]
        if not (self.directory / str(step) / META).is_dir():
            raise Damaged(f"its {META} item is missing")
        ocp = self._ocp
        try:
            with quiet_orbax():
                restored = self.manager.restore(step, args=ocp.args.Composite(**{META: ocp.args.JsonRestore()}))
            meta = restored[META]
        except Exception as e:  # noqa: BLE001 - any Orbax failure is a corrupt checkpoint
            raise Damaged(f"its {META} item is unreadable: {first_line(e, self.directory)}") from None
        if not isinstance(meta, dict):
            raise Damaged(f"its {META} item is not a JSON object")
        return dict(meta)

    def _read_arrays(self, step: int, item: str, specs: list[dict[str, Any]]) -> dict[str, np.ndarray]:
        """The arrays of ``item`` of ``step`` as NumPy, read by the leaf ``specs`` of ``meta``
        (``Damaged`` if the item is missing, unreadable or lacks an array)."""
        ocp = self._ocp
        if not (self.directory / str(step) / item).is_dir():
            raise Damaged(f"its {item} item is missing")
        try:
            abstract = abstract_items(specs)
        except (KeyError, TypeError, ValueError):
            raise Damaged(f"its {META} item has invalid leaf specs for {item}") from None
        try:
            with quiet_orbax():
                args = ocp.args.Composite(**{item: ocp.args.StandardRestore(abstract)})
                restored = self.manager.restore(step, args=args)
            arrays = dict(restored[item])
        except Exception as e:  # noqa: BLE001 - any Orbax failure is a corrupt checkpoint
            raise Damaged(f"its {item} item is unreadable: {first_line(e, self.directory)}") from None
        for key, want in abstract.items():
            have = arrays.get(key)
            if have is None or np.shape(have) != want.shape:
                path = specs[int(key)]["path"]
                raise Damaged(f"its {item} item lacks array {path}" if have is None else f"{path} has the wrong shape")
        return {key: np.asarray(arrays[key]) for key in abstract}

    def _read_step(self, step: int) -> dict[str, Any]:
        """``meta`` and the arrays of ``state`` and ``policy`` of ``step`` (``Damaged`` if any
        part is missing or unreadable)."""
        for item in ITEMS:
            if not (self.directory / str(step) / item).is_dir():
                raise Damaged(f"its {item} item is missing")
        meta = self._meta(step)
        read: dict[str, Any] = {META: meta}
        for item, key in SPECS_KEY.items():
            specs = meta.get(key)
            if not isinstance(specs, list):
                raise Damaged(f"its {META} item lacks {key}")
            read[item] = self._read_arrays(step, item, specs)
        self._verify_checksums(step, meta)
        return read

    def _verify_checksums(self, step: int, meta: dict[str, Any]) -> None:
        """``Damaged`` unless every file of ``step`` matches its manifest; a step without one
        passes if its ``meta`` does not promise one (an older jaxpg wrote it: noted once)."""
        step_dir = self.directory / str(step)
        if (step_dir / MANIFEST).is_file():
            problem = manifest_problem(step_dir)
            if problem is not None:
                raise Damaged(problem)
            return
        if meta.get(CHECKSUMS_KEY):
            raise Damaged("its checksum manifest is missing (the save did not finish)")
        if not self._noted_unverified:
            self._noted_unverified = True
            print(
                f"note: checkpoint {step} in {self.directory} has no checksum manifest (written by an older "
                "jaxpg): its bytes cannot be verified",
                file=sys.stderr,
            )

    def _forget(self, step: int) -> None:
        """Drop what was cached about ``step``."""
        self._scores.pop(step, None)
        self._damage.pop(step, None)
        self._read.pop(step, None)

    def _restore_item(self, step: int, item: str, target: Any, expect: dict | None) -> Any:
        """``item`` of ``step`` as the pytree ``target`` (checked against ``meta`` first)."""
        where = f"checkpoint step {step} in {self.directory}"
        meta = self.read_meta(step)
        for key, value in (expect or {}).items():
            if key in meta and meta[key] != value:
                raise CheckpointError(f"{where} is of {key} {meta[key]!r}, this run's is {value!r}")
        expected = leaf_specs(target)
        check_specs(meta.get(SPECS_KEY[item], []), expected, where)
        if step not in self._read:  # not checked yet (asked for by number): check the whole step now
            self._damage.pop(step, None)
        reason = self.damage(step)
        if reason is not None:
            raise CheckpointError(f"{where} is damaged ({reason}); steps: {self.steps()}")
        arrays = self._read.pop(step)[item]
        abstract, treedef = jax.tree.flatten(target)
        # Via NumPy: uncommitted arrays, like a fresh init's, so jit reuses its compiled step.
        leaves = [
            jax.numpy.asarray(arrays[leaf_key(i)]) if leaf_key(i) in arrays else jax.numpy.zeros(np.shape(x), x.dtype)
            for i, x in enumerate(abstract)
        ]
        return jax.tree.unflatten(treedef, leaves)

    def restore(self, target: Any, step: int | str | None = None, expect: dict[str, Any] | None = None) -> Any:
        """The ``TrainState`` saved as ``step`` (``None``/``"latest"``, ``"best"`` or a number).

        ``target``: a ``TrainState`` of the same run, or its ``jax.eval_shape`` (only paths,
        shapes, dtypes and the static fields are used). ``expect``: meta values that must match,
        e.g. ``{"task": "hopper", "algo": "npg"}``. ``"latest"``/``"best"`` skip damaged steps
        with a warning line. Raises ``CheckpointError`` (one line) for a missing, corrupt or
        incompatible checkpoint; nothing on disk is changed.
        """
        return self._restore_item(self.resolve_step(step), STATE, target, expect)

    def restore_policy(self, target: Any, step: int | str | None = None, expect: dict[str, Any] | None = None) -> Any:
        """``{"params", "obs_stats"}`` saved as ``step``; ``target`` as ``policy_part`` of a state
        (or its ``eval_shape``)."""
        return self._restore_item(self.resolve_step(step), POLICY, target, expect)

    def close(self) -> None:
        """Close the Orbax manager and drop cached arrays."""
        self._read.clear()
        self.manager.close()
