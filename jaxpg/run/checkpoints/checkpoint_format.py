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
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import jax
import numpy as np

from jaxpg.run.checkpoints.checkpoint_errors import CheckpointError

STATE, POLICY, META = "state", "policy", "meta"


ITEMS = (STATE, POLICY, META)


COMMIT_MARKER = "commit_success.txt"  # what Orbax writes into a step just before it renames it


STEP_METADATA = "_CHECKPOINT_METADATA"


SPECS_KEY = {STATE: "state_leaves", POLICY: "policy_leaves"}


MANIFEST = "jaxpg_sha256.json"  # sha256 of every other file of a step, written once it is complete


CHECKSUMS_KEY = "checksums"  # in meta: the writer adds a manifest to this step


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


def check_specs(saved: list[dict], expected: list[dict], where: str) -> None:
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


def is_committed(path: Path) -> bool:
    """Whether the step directory ``path`` was finalised by Orbax: it has the commit marker (or,
    from Orbax versions that wrote none, a commit time in its step metadata)."""
    if (path / COMMIT_MARKER).is_file():
        return True
    try:
        return json.loads((path / STEP_METADATA).read_text()).get("commit_timestamp_nsecs") is not None
    except (OSError, ValueError, AttributeError):
        return False


def abstract_items(specs: list[dict[str, Any]]) -> dict[str, np.ndarray]:
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


def find_tmp_dirs(directory: str | os.PathLike) -> Sequence[Path]:
    """Temporary directories left by writes that never finished (safe to delete)."""
    directory = Path(directory)
    if not directory.is_dir():
        return []
    return sorted(p for p in directory.iterdir() if p.is_dir() and "orbax-checkpoint-tmp" in p.name)
