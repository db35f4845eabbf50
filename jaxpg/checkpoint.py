"""Checkpoints of whole ``TrainState``s with Orbax.

A checkpoint holds every array of the ``TrainState`` pytree: policy and value parameters,
optimizer states, RNG key, env states, iteration counter, observation-normalisation statistics
(with a leading seed axis when several seeds train together). The pytree's *structure* is not
stored as such: a restore needs a target, the state the algorithm's ``init`` builds from the
saved config (``jax.eval_shape`` of it costs no computation), and checks every array's path,
shape and dtype against it before reading any data, so that a checkpoint of another task,
algorithm or network shape fails with one clear error instead of a deep Orbax traceback.

Each checkpoint step is a directory of three Orbax items:
  ``state``  the TrainState's arrays, flattened (leaf ``i`` under the key ``"%05d" % i``);
  ``policy`` the policy parameters and observation statistics alone, so that
             ``jaxpg.load_policy`` restores them without building the env;
  ``meta``   JSON: step, score, metrics of the last iteration, task, algorithm, and the path,
             shape and dtype of every leaf of ``state`` and ``policy``.
Orbax writes a step into a temporary directory and renames it when complete, so a process
killed while writing loses that checkpoint only; leftover temporary directories are ignored.

Retention: the ``keep`` latest steps plus the best one (highest ``score``: the latest
``return_mean_policy``, falling back to ``return_stochastic``).

Several processes (``jaxpg.distributed``): every process calls ``save``, which gathers the
state to the host (a collective: arrays split over processes are all-gathered); process 0 alone
writes. Every process restores, each reading the files itself (a shared file system across
hosts), onto its own first device; ``jaxpg.cli.shard_state`` then places the state on the
global mesh. Each process's Orbax manager works alone (no barriers across processes).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import jax
import numpy as np

from jaxpg import distributed

STATE, POLICY, META = "state", "policy", "meta"


class CheckpointError(ValueError):
    """A checkpoint is missing, corrupt or does not fit the run; the message is one line."""


def leaf_key(i: int) -> str:
    return f"{i:05d}"


def leaf_specs(tree: Any) -> list[dict[str, Any]]:
    """``[{path, shape, dtype}]`` of every leaf of ``tree`` (arrays or ``ShapeDtypeStruct``s)."""
    leaves, _ = jax.tree_util.tree_flatten_with_path(tree)
    return [
        {"path": jax.tree_util.keystr(path), "shape": list(np.shape(x)), "dtype": str(np.dtype(x.dtype))}
        for path, x in leaves
    ]


def policy_part(ts: Any) -> dict[str, Any]:
    """What ``load_policy`` needs from a ``TrainState``: policy params and observation stats."""
    return {"params": ts.params, "obs_stats": ts.obs_stats}


def _check_specs(saved: list[dict], expected: list[dict], where: str) -> None:
    """``CheckpointError`` naming the first leaf whose path, shape or dtype differs."""
    if len(saved) != len(expected):
        raise CheckpointError(
            f"{where} holds {len(saved)} arrays but this run's state has {len(expected)} "
            "(another task, algorithm or network?)"
        )
    for s, e in zip(saved, expected, strict=True):
        if s["path"] != e["path"] or list(s["shape"]) != list(e["shape"]) or s["dtype"] != e["dtype"]:
            have = f"{s['path']} {s['dtype']}{list(s['shape'])}"
            want = f"{e['path']} {e['dtype']}{list(e['shape'])}"
            raise CheckpointError(
                f"{where} does not fit this run: it has {have} where {want} is expected "
                "(another task, algorithm, network shape or number of envs/seeds?)"
            )


def _first_line(e: BaseException) -> str:
    text = str(e).strip().splitlines()
    return f"{type(e).__name__}: {text[0] if text else ''}".strip()


class Checkpointer:
    """Saves and restores ``TrainState``s under ``directory`` (a run's ``checkpoints/``).

    Args:
      directory: the checkpoint directory.
      keep: how many of the latest steps to keep (the best step is kept as well); ``None``
        keeps all.
      create: create ``directory`` if missing (for writing); readers leave it ``False`` so that
        a missing directory is an error and nothing is created.
    """

    def __init__(self, directory: str | os.PathLike, keep: int | None = 3, create: bool = False):
        import orbax.checkpoint as ocp

        self.directory = Path(directory).absolute()
        self.keep = keep
        self.writer = distributed.is_primary()
        if not create and not self.directory.is_dir():
            raise CheckpointError(f"no checkpoints: {self.directory} does not exist")
        self._ocp = ocp
        multiprocessing: dict[str, Any] = {}
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
        self._scores: dict[int, float] = {}

    # ---- queries

    def steps(self) -> list[int]:
        """Completed checkpoint steps, ascending (temporary directories of unfinished writes are
        not steps)."""
        self.manager.reload()
        return sorted(int(s) for s in self.manager.all_steps())

    def latest_step(self) -> int | None:
        steps = self.steps()
        return steps[-1] if steps else None

    def read_meta(self, step: int) -> dict[str, Any]:
        """The ``meta`` item of ``step``."""
        try:
            restored = self.manager.restore(step, args=self._ocp.args.Composite(**{META: self._ocp.args.JsonRestore()}))
            return dict(restored[META])
        except Exception as e:  # noqa: BLE001 - any Orbax failure is a corrupt checkpoint
            raise CheckpointError(
                f"checkpoint step {step} in {self.directory} is unreadable ({_first_line(e)})"
            ) from None

    def score(self, step: int) -> float:
        if step not in self._scores:
            try:
                value = self.read_meta(step).get("score")
            except CheckpointError:
                value = None
            self._scores[step] = -math.inf if value is None else float(value)
        return self._scores[step]

    def best_step(self) -> int | None:
        """The step with the highest score (the latest among equals)."""
        steps = self.steps()
        if not steps:
            return None
        return max(steps, key=lambda s: (self.score(s), s))

    def resolve_step(self, step: int | str | None) -> int:
        """``None``/``"latest"``, ``"best"`` or a step number -> an existing step."""
        steps = self.steps()
        if not steps:
            raise CheckpointError(f"no checkpoint in {self.directory}")
        if step is None or step == "latest":
            return steps[-1]
        if step == "best":
            return self.best_step()  # type: ignore[return-value]
        try:
            step = int(step)
        except (TypeError, ValueError):
            raise CheckpointError(f"checkpoint step must be a number, 'latest' or 'best', got {step!r}") from None
        if step not in steps:
            raise CheckpointError(f"no checkpoint of step {step} in {self.directory}; steps: {steps}")
        return step

    # ---- save

    def save(
        self,
        step: int,
        train_state: Any,
        score: float = -math.inf,
        metrics: dict[str, float] | None = None,
        info: dict[str, Any] | None = None,
    ) -> None:
        """Save ``train_state`` as ``step`` (synchronously), then apply the retention policy.

        ``score`` ranks checkpoints for "best"; ``metrics`` and ``info`` (task, algorithm ...)
        go to ``meta``. Arrays are copied to the host first, so the caller may donate
        ``train_state``'s buffers right after. With several processes every process calls
        ``save`` (the copy gathers arrays split over processes) and process 0 alone writes.
        """
        ocp = self._ocp
        train_state = distributed.host_copy(train_state)
        if not self.writer:
            return
        state_leaves = [np.asarray(x) for x in jax.tree.leaves(train_state)]
        policy = policy_part(train_state)
        policy_leaves = [np.asarray(x) for x in jax.tree.leaves(policy)]
        score = float(score) if score is not None and math.isfinite(float(score)) else -math.inf
        meta = {
            "step": int(step),
            "score": score if math.isfinite(score) else None,
            "metrics": {
                k: (float(v) if v is not None and math.isfinite(float(v)) else None) for k, v in (metrics or {}).items()
            },
            **(info or {}),
            "state_leaves": leaf_specs(train_state),
            "policy_leaves": leaf_specs(policy),
        }
        # Orbax cannot write zero-size arrays (MJX has empty contact arrays in contact-free
        # models); they are rebuilt from the leaf specs on restore.
        state_items = {leaf_key(i): x for i, x in enumerate(state_leaves) if x.size}
        policy_items = {leaf_key(i): x for i, x in enumerate(policy_leaves) if x.size}
        if step in self.steps():
            self.manager.delete(step)
        self.manager.save(
            int(step),
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
        self._scores[int(step)] = score
        self._apply_retention()

    def _apply_retention(self) -> None:
        if self.keep is None:
            return
        steps = self.steps()
        keep = set(steps[-self.keep :]) if self.keep > 0 else set()
        best = self.best_step()
        if best is not None:
            keep.add(best)
        for step in steps:
            if step not in keep:
                self.manager.delete(step)
                self._scores.pop(step, None)

    # ---- restore

    def _restore_item(self, step: int, item: str, target: Any, specs_key: str, expect: dict | None) -> Any:
        ocp = self._ocp
        meta = self.read_meta(step)
        where = f"checkpoint step {step} in {self.directory}"
        for key, value in (expect or {}).items():
            if key in meta and meta[key] != value:
                raise CheckpointError(f"{where} is of {key} {meta[key]!r}, this run's is {value!r}")
        expected = leaf_specs(target)
        _check_specs(meta.get(specs_key, []), expected, where)
        abstract, treedef = jax.tree.flatten(target)
        device = jax.local_devices()[0]
        sharding = jax.sharding.SingleDeviceSharding(device)
        items = {
            leaf_key(i): jax.ShapeDtypeStruct(np.shape(x), x.dtype, sharding=sharding)
            for i, x in enumerate(abstract)
            if np.prod(np.shape(x), dtype=np.int64) > 0
        }
        try:
            restored = self.manager.restore(step, args=ocp.args.Composite(**{item: ocp.args.StandardRestore(items)}))
            arrays = restored[item]
        except Exception as e:  # noqa: BLE001 - any Orbax failure is a corrupt checkpoint
            raise CheckpointError(f"{where} is unreadable ({_first_line(e)})") from None
        leaves = []
        for i, x in enumerate(abstract):
            key = leaf_key(i)
            if key in items:
                if key not in arrays:
                    raise CheckpointError(f"{where} is incomplete: array {expected[i]['path']} is missing")
                # Via NumPy: uncommitted arrays, like a fresh init's, so jit reuses its compiled step.
                leaves.append(jax.numpy.asarray(np.asarray(arrays[key])))
            else:
                leaves.append(jax.numpy.zeros(np.shape(x), x.dtype))
        return jax.tree.unflatten(treedef, leaves)

    def restore(self, target: Any, step: int | str | None = None, expect: dict[str, Any] | None = None) -> Any:
        """The ``TrainState`` saved as ``step`` (``None``/``"latest"``, ``"best"`` or a number).

        ``target``: a ``TrainState`` of the same run, or its ``jax.eval_shape`` (only paths,
        shapes, dtypes and the static fields are used). ``expect``: meta values that must match,
        e.g. ``{"task": "hopper", "algo": "npg"}``. Raises ``CheckpointError`` (one line) for a
        missing, corrupt or incompatible checkpoint; nothing on disk is changed.
        """
        return self._restore_item(self.resolve_step(step), STATE, target, "state_leaves", expect)

    def restore_policy(self, target: Any, step: int | str | None = None, expect: dict[str, Any] | None = None) -> Any:
        """``{"params", "obs_stats"}`` saved as ``step``; ``target`` as ``policy_part`` of a state
        (or its ``eval_shape``)."""
        return self._restore_item(self.resolve_step(step), POLICY, target, "policy_leaves", expect)

    def close(self) -> None:
        self.manager.close()


def find_tmp_dirs(directory: str | os.PathLike) -> Sequence[Path]:
    """Temporary directories left by writes that never finished (safe to delete)."""
    directory = Path(directory)
    if not directory.is_dir():
        return []
    return sorted(p for p in directory.iterdir() if p.is_dir() and "orbax-checkpoint-tmp" in p.name)
