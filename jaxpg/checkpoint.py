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
Orbax writes a step into a temporary directory, writes the commit marker
(``commit_success.txt``) into it and renames it when complete, so a process killed while
writing loses that checkpoint only. Only committed steps count: leftover temporary directories
and step directories without the commit marker are ignored.

Checksums: once a step is committed and its policy reads back, the writer adds
``jaxpg_sha256.json`` to the step directory (written to a temporary file and renamed, so it is
whole or absent): the sha256 of every other file of the step. ``meta`` records that a manifest
follows (``"checksums": "sha256"``), so a step whose manifest never got written is damaged, not
mistaken for an old one. Steps written before manifests existed (no manifest, no such key in
``meta``) still load, read without byte verification; that is said once per ``Checkpointer`` on
stderr (a ``note:`` line).

Damage: every read of a step's arrays checks the whole step: its items are present, its ``meta``
parses, every array of ``state`` and ``policy`` reads, then every file matches its checksum
(flipped bytes that still parse are caught here). ``"latest"`` and ``"best"`` (and
``latest_step``) mean the newest (best) checkpoint that passes; a damaged step is skipped with one
``warning:`` line on stderr naming it and why; nothing on disk is changed. A step asked for by
number is not replaced by another: it is restored if it passes, else one ``CheckpointError``.
The arrays read while checking a step are kept until it is restored, so that a restore right
after ``latest_step`` reads the files once.

Saving: after writing a step the policy item is read back and compared with what was saved; a
step that does not read back is removed. Disk-full, permission and read-only-file-system errors
become one-line ``CheckpointError``s saying what to do. Every ``CheckpointError`` is one line.

Retention: the ``keep`` latest steps plus the best one (highest ``score``, which the caller
computes, e.g. ``jaxpg.run.metrics_log.checkpoint_score``); the newest step is always kept, whatever
``keep`` is, so that the final checkpoint of a run survives.

Several processes (``jaxpg.run.processes``): every process calls ``save``, which gathers the
state to the host (a collective: arrays split over processes are all-gathered); process 0 alone
writes. Every process restores, each reading the files itself (a shared file system across
hosts), onto its own first device; ``jaxpg.algos.core.shard_state`` then places the state on the
global mesh. Each process's Orbax manager works alone (no barriers across processes).
"""

from __future__ import annotations

import contextlib
import errno
import gc
import hashlib
import json
import logging
import math
import os
import re
import shutil
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import jax
import numpy as np

from jaxpg import mesh as mesh_lib
from jaxpg.run import processes

STATE, POLICY, META = "state", "policy", "meta"
ITEMS = (STATE, POLICY, META)
COMMIT_MARKER = "commit_success.txt"  # what Orbax writes into a step just before it renames it
STEP_METADATA = "_CHECKPOINT_METADATA"
SPECS_KEY = {STATE: "state_leaves", POLICY: "policy_leaves"}
MANIFEST = "jaxpg_sha256.json"  # sha256 of every other file of a step, written once it is complete
CHECKSUMS_KEY = "checksums"  # in meta: the writer adds a manifest to this step
MAX_REASON = 160  # characters of an Orbax/TensorStore error kept in a message


class CheckpointError(ValueError):
    """A checkpoint is missing, corrupt or does not fit the run; the message is one line."""


class _Damaged(Exception):
    """A step that does not read back completely; the message says why (short, one line)."""


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


# ---- one-line errors


def _clip(text: str, limit: int = MAX_REASON) -> str:
    """``text`` on one line, at most ``limit`` characters (``...`` marks a cut)."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3].rstrip() + "..."


_TS_STATUS = re.compile(
    r"\b(NOT_FOUND|OUT_OF_RANGE|DATA_LOSS|INVALID_ARGUMENT|FAILED_PRECONDITION|PERMISSION_DENIED|"
    r"RESOURCE_EXHAUSTED|UNAVAILABLE|INTERNAL|UNKNOWN|ABORTED|ALREADY_EXISTS)\b"
)
_TS_FILE = re.compile(r'local file "([^"]+)"')


def _first_line(e: BaseException, root: Path | None = None) -> str:
    """A short one-line description of ``e``: for TensorStore errors (kilobytes of driver specs)
    the status and the file it failed on (relative to ``root``), else the type and first line."""
    text = str(e)
    status, files = _TS_STATUS.search(text), _TS_FILE.findall(text)
    if status and files:
        path = files[-1]
        if root is not None and path.startswith(str(root) + os.sep):
            path = path[len(str(root)) + 1 :]
        return _clip(f"{status.group(1).lower().replace('_', ' ')}: {path}")
    lines = text.strip().splitlines()
    line = re.sub(r"\s*\[tensorstore_spec=.*", "", lines[0]) if lines else ""
    return _clip(f"{type(e).__name__}: {line}".rstrip(": "))


def _chain(e: BaseException) -> Iterator[BaseException]:
    """``e``, its causes and contexts, and the members of exception groups, each once."""
    seen: set[int] = set()
    todo = [e]
    while todo:
        x = todo.pop()
        if x is None or id(x) in seen:
            continue
        seen.add(id(x))
        yield x
        todo.extend([x.__cause__, x.__context__, *getattr(x, "exceptions", ())])


_ERRNO_TEXT = {
    errno.ENOSPC: ("no space left on device",),
    errno.EDQUOT: ("disk quota exceeded",),
    errno.EACCES: ("permission denied",),
    errno.EPERM: ("operation not permitted",),
    errno.EROFS: ("read-only file system",),
}


def _os_errno(e: BaseException) -> tuple[int, str | None] | None:
    """``(errno, filename)`` of the first disk-full/permission/read-only error in ``e``'s chain,
    also when a library (TensorStore) reports it as text; ``None`` for other errors."""
    for x in _chain(e):
        if isinstance(x, OSError) and x.errno in _ERRNO_TEXT:
            return x.errno, x.filename
    for x in _chain(e):
        text = str(x).lower()
        for code, words in _ERRNO_TEXT.items():
            if any(w in text for w in words):
                return code, None
    return None


def _save_advice(code: int) -> str:
    """What happened and what to do, for a save that failed with ``code``."""
    if code in (errno.ENOSPC, errno.EDQUOT):
        what = "the disk is full" if code == errno.ENOSPC else "the disk quota is exceeded"
        return f"{what}; free some space (or keep fewer checkpoints: --keep-checkpoints), then continue with --resume"
    if code == errno.EROFS:
        return "the file system is read-only; write the run to a writable place (--run-dir)"
    return "permission denied; make the directory writable for this user, or choose another --run-dir"


# ---- quiet restore attempts


def _drop_closed_loop_noise(hook: Any) -> Any:
    """An ``unraisablehook`` that drops the ``RuntimeError: Event loop is closed`` TensorStore
    raises when reads still in flight after a failed Orbax restore complete on its closed loop;
    everything else goes to ``hook``."""

    def filtered(unraisable: Any) -> None:
        if isinstance(unraisable.exc_value, RuntimeError) and "Event loop is closed" in str(unraisable.exc_value):
            return
        hook(unraisable)

    filtered.drops_closed_loop_noise = True  # type: ignore[attr-defined]
    return filtered


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """Silence Orbax/absl log lines and asyncio task tracebacks during a read or write that may
    fail (the failure is reported as one ``CheckpointError`` line instead)."""
    if not getattr(sys.unraisablehook, "drops_closed_loop_noise", False):  # these arrive later, from other threads
        sys.unraisablehook = _drop_closed_loop_noise(sys.unraisablehook)
    loggers = [logging.getLogger(name) for name in ("absl", "asyncio", "orbax")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    except BaseException:
        gc.collect()  # "Task exception was never retrieved" is logged when a failed task is freed
        raise
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)


def _is_committed(path: Path) -> bool:
    """Whether the step directory ``path`` was finalised by Orbax: it has the commit marker (or,
    from Orbax versions that wrote none, a commit time in its step metadata)."""
    if (path / COMMIT_MARKER).is_file():
        return True
    try:
        return json.loads((path / STEP_METADATA).read_text()).get("commit_timestamp_nsecs") is not None
    except (OSError, ValueError, AttributeError):
        return False


def _abstract_items(specs: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """The Orbax restore target of an item saved with leaf ``specs``: an empty NumPy array per
    non-empty leaf (zero-size leaves are not written), so that arrays come back as NumPy."""
    return {
        leaf_key(i): np.empty(tuple(s["shape"]), jax.numpy.dtype(s["dtype"]))
        for i, s in enumerate(specs)
        if math.prod(s["shape"]) > 0
    }


def file_sha256(path: Path) -> str:
    """The sha256 of the bytes of ``path`` (hex), read in 1 MiB pieces."""
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def step_digests(step_dir: Path) -> dict[str, str]:
    """``{path relative to step_dir: sha256}`` of every file of a step directory except the manifest."""
    files = (p for p in step_dir.rglob("*") if p.is_file() and not p.name.startswith(MANIFEST))
    return {p.relative_to(step_dir).as_posix(): file_sha256(p) for p in sorted(files)}


def write_manifest(step_dir: Path) -> None:
    """Write ``step_dir/MANIFEST`` atomically (a temporary file, flushed to disk, then renamed)."""
    data = {"format": 1, "algorithm": "sha256", "files": step_digests(step_dir)}
    tmp = step_dir / (MANIFEST + ".tmp")
    with tmp.open("w") as f:
        json.dump(data, f, indent=1, sort_keys=True)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, step_dir / MANIFEST)


def manifest_problem(step_dir: Path) -> str | None:
    """Why the files of ``step_dir`` do not match its manifest (one short line), or ``None`` when
    they all do. A missing manifest is the caller's to judge (an older checkpoint, or a save that
    did not finish)."""
    step = step_dir.name
    try:
        files = json.loads((step_dir / MANIFEST).read_text())["files"]
        entries = sorted(files.items())
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return "its checksum manifest is unreadable"
    for rel, digest in entries:
        if (
            not isinstance(rel, str)
            or not isinstance(digest, str)
            or ".." in Path(rel).parts
            or Path(rel).is_absolute()
        ):
            return "its checksum manifest is unreadable"
        path = step_dir / rel
        if not path.is_file():
            return f"{step}/{rel} is missing"
        if file_sha256(path) != digest:
            return f"{step}/{rel} does not match its sha256 checksum (its bytes changed after the save)"
    return None


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
            found = _os_errno(e)
            if found is None:
                raise CheckpointError(f"cannot open checkpoint directory {self.directory} ({_first_line(e)})") from None
            raise CheckpointError(
                f"cannot create checkpoint directory {self.directory}: {_save_advice(found[0])}"
            ) from None
        self._scores: dict[int, float] = {}
        self._damage: dict[int, str | None] = {}  # step -> why it does not read back (None: it does)
        self._read: dict[int, dict[str, Any]] = {}  # arrays and meta read while checking a step
        self._noted_unverified = False  # the note about steps without a checksum manifest was printed

    # ---- queries

    def steps(self) -> list[int]:
        """Committed checkpoint steps, ascending: temporary directories of unfinished writes and
        step directories without Orbax's commit marker are not steps (damaged ones are)."""
        self.manager.reload()
        return sorted(int(s) for s in self.manager.all_steps() if _is_committed(self.directory / str(s)))

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
        except _Damaged as e:
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
            except _Damaged as e:
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

    # ---- reading

    def _meta(self, step: int) -> dict[str, Any]:
        """``meta`` of ``step`` (``_Damaged`` if missing or unreadable)."""
        if step in self._read:
            return self._read[step][META]
        if not (self.directory / str(step) / META).is_dir():
            raise _Damaged(f"its {META} item is missing")
        ocp = self._ocp
        try:
            with _quiet():
                restored = self.manager.restore(step, args=ocp.args.Composite(**{META: ocp.args.JsonRestore()}))
            meta = restored[META]
        except Exception as e:  # noqa: BLE001 - any Orbax failure is a corrupt checkpoint
            raise _Damaged(f"its {META} item is unreadable: {_first_line(e, self.directory)}") from None
        if not isinstance(meta, dict):
            raise _Damaged(f"its {META} item is not a JSON object")
        return dict(meta)

    def _read_arrays(self, step: int, item: str, specs: list[dict[str, Any]]) -> dict[str, np.ndarray]:
        """The arrays of ``item`` of ``step`` as NumPy, read by the leaf ``specs`` of ``meta``
        (``_Damaged`` if the item is missing, unreadable or lacks an array)."""
        ocp = self._ocp
        if not (self.directory / str(step) / item).is_dir():
            raise _Damaged(f"its {item} item is missing")
        try:
            abstract = _abstract_items(specs)
        except (KeyError, TypeError, ValueError):
            raise _Damaged(f"its {META} item has invalid leaf specs for {item}") from None
        try:
            with _quiet():
                args = ocp.args.Composite(**{item: ocp.args.StandardRestore(abstract)})
                restored = self.manager.restore(step, args=args)
            arrays = dict(restored[item])
        except Exception as e:  # noqa: BLE001 - any Orbax failure is a corrupt checkpoint
            raise _Damaged(f"its {item} item is unreadable: {_first_line(e, self.directory)}") from None
        for key, want in abstract.items():
            have = arrays.get(key)
            if have is None or np.shape(have) != want.shape:
                path = specs[int(key)]["path"]
                raise _Damaged(f"its {item} item lacks array {path}" if have is None else f"{path} has the wrong shape")
        return {key: np.asarray(arrays[key]) for key in abstract}

    def _read_step(self, step: int) -> dict[str, Any]:
        """``meta`` and the arrays of ``state`` and ``policy`` of ``step`` (``_Damaged`` if any
        part is missing or unreadable)."""
        for item in ITEMS:
            if not (self.directory / str(step) / item).is_dir():
                raise _Damaged(f"its {item} item is missing")
        meta = self._meta(step)
        read: dict[str, Any] = {META: meta}
        for item, key in SPECS_KEY.items():
            specs = meta.get(key)
            if not isinstance(specs, list):
                raise _Damaged(f"its {META} item lacks {key}")
            read[item] = self._read_arrays(step, item, specs)
        self._verify_checksums(step, meta)
        return read

    def _verify_checksums(self, step: int, meta: dict[str, Any]) -> None:
        """``_Damaged`` unless every file of ``step`` matches its manifest; a step without one
        passes if its ``meta`` does not promise one (an older jaxpg wrote it: noted once)."""
        step_dir = self.directory / str(step)
        if (step_dir / MANIFEST).is_file():
            problem = manifest_problem(step_dir)
            if problem is not None:
                raise _Damaged(problem)
            return
        if meta.get(CHECKSUMS_KEY):
            raise _Damaged("its checksum manifest is missing (the save did not finish)")
        if not self._noted_unverified:
            self._noted_unverified = True
            print(
                f"note: checkpoint {step} in {self.directory} has no checksum manifest (written by an older "
                "jaxpg): its bytes cannot be verified",
                file=sys.stderr,
            )

    # ---- save

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
            found = _os_errno(e)
            if found is None:
                raise CheckpointError(
                    f"cannot save checkpoint {step} in {self.directory} ({_first_line(e, self.directory)})"
                ) from None
            code, filename = found
            where = f" ({filename})" if filename else ""
            raise CheckpointError(
                f"cannot save checkpoint {step} in {self.directory}{where}: {_save_advice(code)}"
            ) from None
        self._check_saved_policy(step, policy_items, meta[SPECS_KEY[POLICY]])
        try:
            write_manifest(self.directory / str(step))
        except OSError as e:
            self._remove_step(step)
            code = e.errno if e.errno in _ERRNO_TEXT else None
            advice = _save_advice(code) if code is not None else _first_line(e, self.directory)
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
        with _quiet():
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
            if not _is_committed(self.directory / str(step)):
                raise _Damaged("it has no commit marker")
            back = self._read_arrays(step, POLICY, specs)
            for key, x in saved.items():
                if not np.array_equal(back[key], x, equal_nan=x.dtype.kind in "fc"):
                    raise _Damaged(f"array {specs[int(key)]['path']} differs from what was saved")
        except _Damaged as e:
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

    def _forget(self, step: int) -> None:
        """Drop what was cached about ``step``."""
        self._scores.pop(step, None)
        self._damage.pop(step, None)
        self._read.pop(step, None)

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
                    code = e.errno if e.errno in _ERRNO_TEXT else errno.EACCES
                    raise CheckpointError(
                        f"cannot delete old checkpoint {step} in {self.directory}: {_save_advice(code)}"
                    ) from None
                self._forget(step)

    # ---- restore

    def _restore_item(self, step: int, item: str, target: Any, expect: dict | None) -> Any:
        """``item`` of ``step`` as the pytree ``target`` (checked against ``meta`` first)."""
        where = f"checkpoint step {step} in {self.directory}"
        meta = self.read_meta(step)
        for key, value in (expect or {}).items():
            if key in meta and meta[key] != value:
                raise CheckpointError(f"{where} is of {key} {meta[key]!r}, this run's is {value!r}")
        expected = leaf_specs(target)
        _check_specs(meta.get(SPECS_KEY[item], []), expected, where)
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


def find_tmp_dirs(directory: str | os.PathLike) -> Sequence[Path]:
    """Temporary directories left by writes that never finished (safe to delete)."""
    directory = Path(directory)
    if not directory.is_dir():
        return []
    return sorted(p for p in directory.iterdir() if p.is_dir() and "orbax-checkpoint-tmp" in p.name)
