"""The run directory on the host: ``config.json``, ``metrics.jsonl``, TensorBoard events, the
progress bar and the one-line summaries.

Layout of a run directory (``jaxpg.cli`` writes it, ``jaxpg.load_policy`` and
``python -m jaxpg.evaluate`` read it)::

    config.json      everything to rerun: task, env kwargs, algorithm, full Config, seeds, versions
    metrics.jsonl    one JSON object per iteration (and seed); null: not measured (no evaluation or no
                     episode ended); a measured value that is not finite: "nan", "inf" or "-inf"
    tensorboard/     TensorBoard event files of the same scalars, one sub-directory per seed
    curves.png       returns over iterations (jaxpg.run.outputs.plotting)
    checkpoints/     Orbax checkpoints of the whole TrainState (jaxpg.run.checkpoints.checkpointer)
    videos/          rollouts of the mean policy (jaxpg.video), only with --video-every
    profile.json     phase timings, only with --profile
    .jaxpg.lock      the process writing the directory, while it runs

A directory holding only these (``jaxpg.run.outputs.sinks.run_entries``: the run's own files and what
its registered sinks declare, with their temporary ``*.tmp`` files; inside them only what the
sinks declare and Orbax's checkpoint steps) whose ``config.json`` reads as a ``RunConfig`` is a
jaxpg run (``jaxpg.run.rundir.directory.check_replaceable``): ``--overwrite`` replaces nothing else.

Iterations are counted from 1: the record with ``iteration == n`` describes the n-th update, and
the checkpoint of step ``n`` holds the state after it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

CONFIG_FILE = "config.json"


METRICS_FILE = "metrics.jsonl"


TENSORBOARD_DIR = "tensorboard"


CHECKPOINT_DIR = "checkpoints"


VIDEO_DIR = "videos"


CURVES_FILE = "curves.png"


PROFILE_FILE = "profile.json"


LOCK_FILE = ".jaxpg.lock"


FORMAT_VERSION = 1


MAX_SEED = 2**32 - 1  # PRNG seeds are 32 bits (JAX without x64): larger ones would collide with smaller ones


class RunDirError(ValueError):
    """A run directory is missing, foreign or unreadable (the message is one line)."""


def check_path(path: str | os.PathLike, what: str) -> None:
    """``RunDirError`` (one line) when ``path`` cannot exist on this system: a name in it longer
    than the file system's limit (``NAME_MAX``, 255 bytes on Linux) or the whole path longer than
    ``PATH_MAX``. ``what`` names the path in the message (``--run-dir``)."""
    path = Path(path)
    anchor = Path(path.absolute().anchor)
    for parent in path.absolute().parents:  # the nearest existing ancestor tells the file system
        try:
            if parent.is_dir():
                anchor = parent
                break
        except OSError:
            continue
    name_max, path_max = _pathconf(anchor, "PC_NAME_MAX", 255), _pathconf(anchor, "PC_PATH_MAX", 4096)
    shown = str(path) if len(str(path)) <= 60 else str(path)[:28] + "..." + str(path)[-28:]
    for part in path.parts:
        length = len(os.fsencode(part))
        if length > name_max:
            raise RunDirError(
                f"{what}: a name in {shown!r} is {length} bytes long, longer than the {name_max} "
                "this file system allows; choose a shorter name"
            )
    length = len(os.fsencode(str(path.absolute())))
    if length >= path_max:
        raise RunDirError(
            f"{what}: {shown!r} is {length} bytes long, longer than the {path_max - 1} this system allows"
        )


def _pathconf(path: Path, name: str, default: int) -> int:
    try:
        value = os.pathconf(path, name)
    except (OSError, ValueError, AttributeError):
        return default
    return value if value > 0 else default


def _jsonable(value: Any) -> Any:
    if isinstance(value, tuple | list):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_json_atomic(path: Path, data: Any) -> None:
    """Write JSON to ``path`` through a temporary file and a rename."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=False) + "\n")
    os.replace(tmp, path)
