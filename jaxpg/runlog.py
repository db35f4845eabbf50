"""The run directory on the host: ``config.json``, ``metrics.jsonl``, TensorBoard events, the
progress bar and the one-line summaries.

Layout of a run directory (``jaxpg.cli`` writes it, ``jaxpg.load_policy`` and
``python -m jaxpg.evaluate`` read it)::

    config.json      everything to rerun: task, env kwargs, algorithm, full Config, seeds, versions
    metrics.jsonl    one JSON object per iteration (and seed); NaN ("not measured") is written as null
    tensorboard/     tensorboardX event files of the same scalars, one sub-directory per seed
    curves.png       returns over iterations (jaxpg.plotting)
    checkpoints/     Orbax checkpoints of the whole TrainState (jaxpg.checkpoint)
    videos/          rollouts of the mean policy (jaxpg.video), only with --video-every
    profile.json     phase timings, only with --profile
    .jaxpg.lock      the process writing the directory, while it runs

A directory holding only these (and their temporary ``*.tmp`` files) whose ``config.json`` reads
as a ``RunConfig`` is a jaxpg run (``check_replaceable``): ``--overwrite`` replaces nothing else.

Iterations are counted from 1: the record with ``iteration == n`` describes the n-th update, and
the checkpoint of step ``n`` holds the state after it.
"""

from __future__ import annotations

import atexit
import dataclasses
import datetime
import importlib.metadata
import json
import math
import os
import platform
import shlex
import subprocess
import sys
import types
import typing
import warnings
from collections.abc import Sequence
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
# Everything a run writes at the top of its directory, temporary files of atomic writes included.
RUN_ENTRIES = frozenset(
    {CONFIG_FILE, METRICS_FILE, TENSORBOARD_DIR, CHECKPOINT_DIR, VIDEO_DIR, CURVES_FILE, PROFILE_FILE, LOCK_FILE}
    | {CONFIG_FILE + ".tmp", METRICS_FILE + ".tmp", PROFILE_FILE + ".tmp", "curves.tmp.png"}
)


class RunDirError(ValueError):
    """A run directory is missing, foreign or unreadable (the message is one line)."""


# --------------------------------------------------------------------------- config.json


@dataclasses.dataclass
class RunConfig:
    """The contents of ``config.json``: what is needed to rebuild the env, the algorithm's
    ``Config`` and the initial ``TrainState`` of a run, and how the run is scheduled.

    Attributes:
      task: ``jaxpg.envs`` name; env_kwargs: keyword arguments of ``jaxpg.envs.make``.
      algo: ``jaxpg.algos`` name; config: every field of the algorithm's ``Config``.
      seeds: the training seeds; several are trained together in one vmapped program.
      iterations: total iterations of the run.
      log_every, checkpoint_every, video_every: host-side schedule (0: off / only at the end).
      keep_checkpoints: how many of the latest checkpoints to keep (plus the best one).
      preset: the preset (``jaxpg.algos.presets``) the config started from, if any.
      shard: the env batch is sharded over all local devices.
      info: provenance (command line, versions, device, creation time); not needed to rerun.
    """

    task: str
    algo: str
    config: dict[str, Any]
    seeds: list[int]
    iterations: int
    env_kwargs: dict[str, Any] = dataclasses.field(default_factory=dict)
    log_every: int = 10
    checkpoint_every: int = 50
    keep_checkpoints: int = 3
    video_every: int = 0
    preset: str | None = None
    shard: bool = False
    info: dict[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def vmap_seeds(self) -> bool:
        """Several seeds: the TrainState has a leading ``[num_seeds]`` axis."""
        return len(self.seeds) > 1

    @property
    def block_size(self) -> int:
        """Iterations per compiled call: divides every host-side period, so that logging,
        checkpoints, videos and evaluations all fall on block boundaries."""
        size = self.log_every
        eval_every = int(self.config.get("eval_every", 0)) if self.config.get("eval_envs", 0) else 0
        for every in (self.checkpoint_every, self.video_every, eval_every):
            if every > 0:
                size = math.gcd(size, every)
        return max(size, 1)

    def algo_module(self) -> types.ModuleType:
        from jaxpg import algos

        return algos.get(self.algo)

    def algo_config(self) -> Any:
        """The algorithm's ``Config`` with the saved field values."""
        return config_from_dict(self.algo_module().Config, self.config)

    def make_env(self) -> Any:
        """The run's env (``jaxpg.envs.make_shared``: one object per task and arguments)."""
        from jaxpg import envs

        return envs.make_shared(self.task, **self.env_kwargs)

    def to_json(self) -> dict[str, Any]:
        return {"format": FORMAT_VERSION, **dataclasses.asdict(self)}

    def save(self, run_dir: str | os.PathLike) -> None:
        """Write ``config.json`` atomically."""
        write_json_atomic(Path(run_dir) / CONFIG_FILE, self.to_json())

    @classmethod
    def load(cls, run_dir: str | os.PathLike) -> RunConfig:
        """Read ``run_dir/config.json``; ``RunDirError`` (one line) for a missing or foreign
        directory, a path too long to exist, or a field of the wrong type (``coerce``; seeds must
        be distinct and in ``[0, MAX_SEED]``)."""
        check_path(run_dir, "run directory")
        run_dir = Path(run_dir)
        if not run_dir.is_dir():
            if run_dir.exists():
                raise RunDirError(f"{str(run_dir)!r} is not a run directory (it is a file)")
            raise RunDirError(f"run directory {str(run_dir)!r} does not exist")
        path = run_dir / CONFIG_FILE
        if not path.is_file():
            raise RunDirError(f"{str(run_dir)!r} is not a jaxpg run directory (it has no {CONFIG_FILE})")
        try:
            data = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise RunDirError(f"cannot read {path}: {e}") from None
        # What identifies a jaxpg run's config; the other fields are checked one by one below, so
        # that a wrong value in a run's own config is named (``seeds must be ...``).
        identity = {"format": int, "task": str, "algo": str, "config": dict}
        if not isinstance(data, dict) or any(not isinstance(data.get(k), t) for k, t in identity.items()):
            raise RunDirError(f"{path} is not a jaxpg run configuration")
        if data["format"] > FORMAT_VERSION:
            raise RunDirError(f"{path} was written by a newer jaxpg (format {data['format']})")
        types_ = field_types(cls)
        values = {}
        for name, value in data.items():
            if name not in types_:
                continue
            try:
                values[name] = coerce(types_[name], value)
            except ValueError as e:
                raise RunDirError(f"{path}: {name} {e}") from None
        missing = [f.name for f in dataclasses.fields(cls) if f.name not in values and _no_default(f)]
        if missing:
            raise RunDirError(f"{path} lacks {', '.join(missing)}")
        seeds = values["seeds"]
        if not seeds or len(set(seeds)) != len(seeds):
            raise RunDirError(f"{path}: seeds must be distinct integers, at least one, got {seeds}")
        bad = [s for s in seeds if not 0 <= s <= MAX_SEED]
        if bad:
            raise RunDirError(f"{path}: seeds must be integers in [0, {MAX_SEED}], got {bad[0]}")
        return cls(**values)


def _no_default(field: dataclasses.Field) -> bool:
    return field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING


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


def foreign_entries(run_dir: str | os.PathLike) -> list[str]:
    """The names at the top of ``run_dir`` that a jaxpg run does not write (``RUN_ENTRIES``), sorted."""
    return sorted(name for name in os.listdir(run_dir) if name not in RUN_ENTRIES)


def check_replaceable(run_dir: str | os.PathLike, shown: str | os.PathLike | None = None) -> None:
    """``RunDirError`` (one line) unless ``run_dir`` is a jaxpg run that ``--overwrite`` may
    replace: its ``config.json`` reads as a ``RunConfig`` and it holds nothing else than what a
    run writes (``RUN_ENTRIES``). ``shown``: the name to print (default ``run_dir``)."""
    name = str(run_dir if shown is None else shown)
    if not (Path(run_dir) / CONFIG_FILE).is_file():
        raise RunDirError(f"refusing to --overwrite {name!r}: it is not a jaxpg run directory (no {CONFIG_FILE})")
    try:
        RunConfig.load(run_dir)
    except RunDirError as e:
        raise RunDirError(f"refusing to --overwrite {name!r}: it is not a jaxpg run directory ({e})") from None
    foreign = foreign_entries(run_dir)
    if foreign:
        listed = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
        raise RunDirError(
            f"refusing to --overwrite {name!r}: besides a jaxpg run it holds {listed}, which a run does not write; "
            "move them out or choose another --run-dir"
        )


def _resolve_hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def field_types(cls: type) -> dict[str, Any]:
    """``{field name: resolved type}`` of a config dataclass."""
    hints = _resolve_hints(cls)
    return {f.name: hints.get(f.name, Any) for f in dataclasses.fields(cls)}


def strip_optional(tp: Any) -> tuple[Any, bool]:
    """``(T, True)`` for ``T | None``, else ``(tp, False)``."""
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1:
            return args[0], True
    return tp, False


def _describe(tp: Any) -> str:
    """What a value of the field type ``tp`` is, in words (for messages)."""
    tp, optional = strip_optional(tp)
    origin = typing.get_origin(tp) or tp
    if origin in (tuple, list):
        args = [a for a in typing.get_args(tp) if a is not Ellipsis]
        plural = {int: "integers", float: "numbers", str: "strings"}.get(args[0] if args else None)
        text = f"a list of {plural}" if plural else "a list"
    else:
        names = {int: "an integer", float: "a number", str: "a string", bool: "true or false", dict: "an object"}
        text = names.get(origin, getattr(tp, "__name__", str(tp)))
    return text + (" or null" if optional else "")


def coerce(tp: Any, value: Any) -> Any:
    """``value`` (e.g. from JSON, where tuples are lists) as the field type ``tp``; ``ValueError``
    (``"must be an integer, got 'abc'"``) when it is not of that type: an integer for ``int``
    (a float only when whole), a number for ``float``, ``true``/``false`` for ``bool``, a list for
    tuples and lists, an object for ``dict``, one of the values of a ``Literal``."""
    base, optional = strip_optional(tp)
    if value is None:
        if optional or base is Any:
            return None
        raise ValueError(f"must be {_describe(tp)}, got null")
    origin = typing.get_origin(base) or base
    wrong = ValueError(f"must be {_describe(tp)}, got {value!r}")
    if origin in (tuple, list):
        if not isinstance(value, (list, tuple)):
            raise wrong
        args = [a for a in typing.get_args(base) if a is not Ellipsis]
        try:
            items = [coerce(args[0], v) for v in value] if args else list(value)
        except ValueError:
            raise wrong from None
        return tuple(items) if origin is tuple else items
    if origin is typing.Literal:
        if value not in typing.get_args(base):
            raise ValueError(f"must be one of {', '.join(map(repr, typing.get_args(base)))}, got {value!r}")
        return value
    if base is bool:
        if isinstance(value, bool) or (isinstance(value, int) and value in (0, 1)):
            return bool(value)
        raise wrong
    if base is int:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise wrong
        if isinstance(value, float) and not (math.isfinite(value) and value.is_integer()):
            raise wrong
        return int(value)
    if base is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise wrong
        return float(value)
    if base is str or origin is dict:
        if not isinstance(value, origin):
            raise wrong
        return value
    return value


def config_to_dict(config: Any) -> dict[str, Any]:
    """Every field of a config dataclass, JSON-ready (tuples become lists)."""
    return {f.name: _jsonable(getattr(config, f.name)) for f in dataclasses.fields(config)}


def current_field_names(cls: type, values: dict[str, Any]) -> dict[str, Any]:
    """``values`` with the field names of an older version of config class ``cls`` replaced by the
    current ones, as ``cls.OLD_FIELD_NAMES`` maps them (``None``: a field that is gone, dropped);
    a current name already in ``values`` wins over its old name."""
    renamed = dict(values)
    for old, new in getattr(cls, "OLD_FIELD_NAMES", {}).items():
        if old in renamed:
            value = renamed.pop(old)
            if new is not None:
                renamed.setdefault(new, value)
    return renamed


def config_from_dict(cls: type, values: dict[str, Any]) -> Any:
    """``cls(**values)`` with JSON values coerced to the field types, old field names mapped to
    the current ones (``current_field_names``); ``RunDirError`` names a field the config class
    does not have (a run written by another version of the algorithm) or a value of the wrong type
    (``coerce``). Values are checked by ``Config.validate`` after."""
    values = current_field_names(cls, values)
    types_ = field_types(cls)
    unknown = sorted(set(values) - set(types_))
    if unknown:
        raise RunDirError(f"saved config has fields {cls.__module__}.Config does not know: {', '.join(unknown)}")
    coerced = {}
    for name, value in values.items():
        try:
            coerced[name] = coerce(types_[name], value)
        except ValueError as e:
            raise RunDirError(f"saved config field {name} {e}") from None
    return cls(**coerced)


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


def versions() -> dict[str, str]:
    """Versions of Python and the packages a run's numbers depend on."""
    import jaxpg

    out = {"python": platform.python_version(), "jaxpg": jaxpg.__version__}
    for dist in (
        "jax",
        "jaxlib",
        "mujoco",
        "mujoco-mjx",
        "flax",
        "optax",
        "orbax-checkpoint",
        "numpy",
        "warp-lang",
    ):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            pass
    commit = git_commit()
    if commit:
        out["jaxpg_git"] = commit
    return out


def git_commit() -> str | None:
    """The git commit of the jaxpg checkout (with ``+dirty`` when modified), if it is one."""
    root = Path(__file__).resolve().parent.parent
    if not (root / ".git").exists():
        return None

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], cwd=root, capture_output=True, text=True, timeout=5, check=True
        ).stdout.strip()

    try:
        with warnings.catch_warnings():
            # JAX warns about fork() in a threaded process; git is exec-ed at once: harmless.
            warnings.simplefilter("ignore", RuntimeWarning)
            commit = git("rev-parse", "HEAD")
            dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    return commit + ("+dirty" if dirty else "")


def device_info() -> dict[str, Any]:
    """The JAX backend, device kind and count the run used."""
    import jax

    devices = jax.devices()
    return {
        "backend": jax.default_backend(),
        "kind": devices[0].device_kind,
        "count": len(devices),
        "host": platform.node(),
    }


def provenance(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """``info`` of a new run: command line, versions, device, time."""
    argv = list(sys.argv if argv is None else argv)
    return {
        "command": " ".join(_shell_quote(a) for a in argv),
        "versions": versions(),
        "device": device_info(),
        "created": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
    }


def _shell_quote(arg: str) -> str:
    return shlex.quote(arg)


# --------------------------------------------------------------------------- metrics.jsonl

# Keys every record starts with, in this order; the algorithm's diagnostics follow sorted.
LEADING_KEYS = (
    "iteration",
    "seed",
    "env_steps",
    "wall_time_s",
    "return_stochastic",
    "return_mean_policy",
    "episode_length",
    "task_score",
    "task_score_mean_policy",
)


def _scalar(x: Any) -> float | None:
    """A JSON number; NaN/inf (not measured) become ``None``."""
    value = float(x)
    return value if math.isfinite(value) else None


def block_records(
    metrics: dict[str, np.ndarray], first_iteration: int, seeds: Sequence[int], wall_times: Sequence[float]
) -> list[dict[str, Any]]:
    """One record per iteration (and seed) of a block of ``update`` metrics.

    ``metrics`` holds ``[n]`` arrays, or ``[n, num_seeds]`` when several seeds train together;
    ``wall_times[i]`` is the run's wall time at the end of the block's i-th iteration.
    """
    n = len(next(iter(metrics.values())))
    several = len(seeds) > 1
    keys = [k for k in LEADING_KEYS if k in metrics] + sorted(k for k in metrics if k not in LEADING_KEYS)
    records = []
    for i in range(n):
        for s, seed in enumerate(seeds):
            record: dict[str, Any] = {"iteration": first_iteration + i + 1, "seed": int(seed)}
            if "env_steps" in metrics:
                record["env_steps"] = _scalar(metrics["env_steps"][i, s] if several else metrics["env_steps"][i])
            record["wall_time_s"] = round(float(wall_times[i]), 4)
            for key in keys:
                if key not in record:
                    record[key] = _scalar(metrics[key][i, s] if several else metrics[key][i])
            records.append(record)
    return records


# Metric names that earlier versions wrote -> the current ones (read_metrics renames them).
OLD_METRIC_NAMES = {
    "eval_metric": "task_score",
    "eval_metric_mean_policy": "task_score_mean_policy",
    "step_size": "step_length",
}


def read_metrics(path: str | os.PathLike) -> list[dict[str, Any]]:
    """The records of a ``metrics.jsonl`` (a torn last line, from a killed process, is skipped),
    with metric names of earlier versions renamed (``OLD_METRIC_NAMES``)."""
    path = Path(path)
    if path.is_dir():
        path = path / METRICS_FILE
    records = []
    if not path.exists():
        return records
    with path.open() as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue
            if not isinstance(record, dict):
                continue
            records.append({OLD_METRIC_NAMES.get(k, k): v for k, v in record.items()})
    return records


def damaged_metrics_line(path: str | os.PathLike) -> int | None:
    """The number (from 1) of the first line of a ``metrics.jsonl`` that is not a JSON object,
    blank lines and a torn last line (no newline at its end: a process killed while writing it)
    aside; ``None`` when every line reads."""
    with Path(path).open("rb") as f:
        lines = f.read().split(b"\n")
    # The piece after the last newline is a torn line (or empty): a resume drops it.
    for number, line in enumerate(lines[:-1], start=1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except ValueError:  # JSONDecodeError, or bytes that are not UTF-8
            return number
        if not isinstance(record, dict):
            return number
    return None


def truncate_metrics(run_dir: str | os.PathLike, last_iteration: int) -> float:
    """Drop the records after ``last_iteration`` (iterations a resumed run will redo).

    Returns the wall time of the last kept record (0 when none), so that a resumed run's
    ``wall_time_s`` continues from there.
    """
    path = Path(run_dir) / METRICS_FILE
    records = [r for r in read_metrics(path) if r.get("iteration", 0) <= last_iteration]
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w") as f:
        for r in records:
            f.write(json.dumps(r) + "\n")
    os.replace(tmp, path)
    return max((r.get("wall_time_s") or 0.0 for r in records), default=0.0)


class MetricsWriter:
    """Appends records to ``metrics.jsonl`` and the same scalars to TensorBoard.

    TensorBoard gets one sub-directory per seed (``tensorboard/seed_<s>``), scalars keyed by the
    metric name against the iteration; NaN (not measured) is skipped. ``start_iteration`` > 0
    (a resumed run) purges events the interrupted run wrote after that iteration.
    """

    def __init__(
        self,
        run_dir: str | os.PathLike,
        seeds: Sequence[int],
        start_iteration: int = 0,
        tensorboard: bool = True,
    ):
        self.run_dir = Path(run_dir)
        self.seeds = list(seeds)
        self._file = (self.run_dir / METRICS_FILE).open("a")
        self._writers: dict[int, Any] = {}
        if tensorboard:
            try:
                from tensorboardX import SummaryWriter
            except ImportError:
                print("warning: tensorboardX is not installed: no TensorBoard event files", file=sys.stderr)
                seeds = []
            else:
                seeds = self.seeds
            for seed in seeds:
                logdir = self.run_dir / TENSORBOARD_DIR / f"seed_{seed}"
                kwargs = {"purge_step": start_iteration + 1} if start_iteration > 0 else {}
                self._writers[seed] = SummaryWriter(str(logdir), flush_secs=30, **kwargs)

    def write(self, records: Sequence[dict[str, Any]]) -> None:
        for record in records:
            self._file.write(json.dumps(record) + "\n")
            writer = self._writers.get(record["seed"])
            if writer is None:
                continue
            step = record["iteration"]
            for key, value in record.items():
                if key in ("iteration", "seed") or value is None:
                    continue
                writer.add_scalar(key, value, global_step=step)
        self._file.flush()
        for writer in self._writers.values():
            writer.flush()

    def add_text(self, tag: str, text: str) -> None:
        for writer in self._writers.values():
            writer.add_text(tag, text, global_step=0)

    def close(self) -> None:
        self._file.close()
        for writer in self._writers.values():
            writer.close()


# --------------------------------------------------------------------------- console output

# Diagnostics shown in the summary line when the algorithm reports them.
SUMMARY_DIAGNOSTICS = ("kl", "entropy", "step_length", "value_loss", "grad_norm", "cg_residual", "loss")


def _block_stat(values: np.ndarray) -> tuple[float, float]:
    """Mean over the block's iterations (NaN-aware), then mean and std over seeds."""
    values = np.asarray(values, np.float64)
    with np.errstate(all="ignore"), _quiet_nan_warnings():
        per_seed = np.nanmean(values, axis=0) if values.ndim > 1 else np.array([np.nanmean(values)])
        if np.all(np.isnan(per_seed)):
            return math.nan, math.nan
        return float(np.nanmean(per_seed)), float(np.nanstd(per_seed))


class _quiet_nan_warnings:
    def __enter__(self) -> None:
        import warnings

        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()
        warnings.simplefilter("ignore", category=RuntimeWarning)

    def __exit__(self, *exc: Any) -> None:
        self._ctx.__exit__(*exc)


def _fmt(x: float, digits: int = 4) -> str:
    if math.isnan(x):
        return "-"
    if x != 0 and (abs(x) >= 1e5 or abs(x) < 1e-3):
        return f"{x:.{digits - 1}e}"
    return f"{x:.{digits}g}" if abs(x) < 1 else f"{x:.1f}"


def _rate(x: float) -> str:
    for unit, scale in (("M", 1e6), ("k", 1e3)):
        if x >= scale:
            return f"{x / scale:.1f}{unit}"
    return f"{x:.0f}"


def _duration(seconds: float) -> str:
    seconds = max(0, round(seconds))
    return (
        f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"
        if seconds >= 3600
        else f"{seconds // 60}:{seconds % 60:02d}"
    )


def summary_line(
    metrics: dict[str, np.ndarray],
    last_iteration: int,
    total: int,
    steps_per_s: float,
    note: str = "",
    eta_s: float | None = None,
) -> str:
    """One line about a logging block: progress, time left, throughput, returns (mean over the
    block's iterations; ``mean +- std`` over seeds) and the algorithm's main diagnostics.

    ``eta_s``: the estimated seconds left (``None``: not known yet, e.g. while compiling)."""
    several = np.ndim(next(iter(metrics.values()))) > 1

    def stat(key: str, digits: int = 4, spread: bool = True) -> str:
        mean, std = _block_stat(metrics[key])
        text = _fmt(mean, digits)
        if spread and several and not math.isnan(std):
            text += f"±{_fmt(std, 3)}"
        return text

    width = len(str(total))
    parts = [f"[{last_iteration:>{width}}/{total}]"]
    if eta_s is not None and last_iteration < total:
        parts.append(f"ETA {_duration(eta_s)}")
    if "env_steps" in metrics:
        steps = float(np.max(metrics["env_steps"]))
        parts.append(f"steps {steps:,.0f}")
    parts.append(f"{_rate(steps_per_s)} steps/s{note}")
    returns = []
    if "return_stochastic" in metrics:
        returns.append(f"return {stat('return_stochastic')}")
    if "return_mean_policy" in metrics:
        returns.append(f"mean policy {stat('return_mean_policy')}")
    if returns:
        parts.append(" ".join(returns))
    if "episode_length" in metrics:
        parts.append(f"len {stat('episode_length', 3)}")
    for key in SUMMARY_DIAGNOSTICS:
        if key in metrics:
            parts.append(f"{key} {stat(key, 3, spread=False)}")
    for key in ("update_rejected", "nonfinite"):
        if key in metrics and np.nansum(metrics[key]) > 0:
            parts.append(f"{key} {np.nansum(metrics[key]):.0f}")
    return " | ".join(parts)


class Progress:
    """A tqdm bar over iterations (hidden when stderr is not a terminal) plus summary lines.

    ``update`` advances the bar by a block and shows env steps/s and the latest returns;
    ``write`` prints a line above the bar (to stdout).
    """

    def __init__(self, total: int, initial: int = 0, enabled: bool | None = None, desc: str = "train"):
        from tqdm.auto import tqdm

        disable = None if enabled is None else not enabled
        self._tqdm = tqdm
        self.bar = tqdm(total=total, initial=initial, desc=desc, unit="it", dynamic_ncols=True, disable=disable)

    def update(self, n: int, metrics: dict[str, np.ndarray], steps_per_s: float) -> None:
        postfix = {"steps/s": _rate(steps_per_s)}
        for key, label in (("return_stochastic", "R"), ("return_mean_policy", "R_mean")):
            if key in metrics:
                latest = _latest(metrics[key])
                if not math.isnan(latest):
                    postfix[label] = _fmt(latest)
        self.bar.set_postfix(postfix, refresh=False)
        self.bar.update(n)

    def write(self, line: str) -> None:
        self._tqdm.write(line, file=sys.stdout)

    def close(self) -> None:
        self.bar.close()


def _latest(values: np.ndarray) -> float:
    """The last measured (non-NaN) value of a block, averaged over seeds."""
    values = np.asarray(values, np.float64)
    rows = values.reshape(len(values), -1)
    for row in rows[::-1]:
        if not np.all(np.isnan(row)):
            return float(np.nanmean(row))
    return math.nan


def checkpoint_score(metrics: dict[str, np.ndarray], evaluated: bool) -> float:
    """The score a checkpoint saved after a block is ranked by for "best", one kind per run so that
    like is compared with like: when the run evaluates its mean policy (``evaluated``: eval_envs >
    0), the ``return_mean_policy`` of the block's last iteration (the checkpoint's), ``-inf`` when
    that iteration was not evaluated; otherwise the latest measured ``return_stochastic`` of the
    block. Means over seeds; ``-inf`` when nothing was measured."""
    if evaluated:
        if "return_mean_policy" not in metrics:
            return -math.inf
        last = np.asarray(metrics["return_mean_policy"], np.float64)[-1:]
        value = _latest(last)
    else:
        value = _latest(metrics["return_stochastic"]) if "return_stochastic" in metrics else math.nan
    return -math.inf if math.isnan(value) else value


def latest_score(metrics: dict[str, np.ndarray]) -> float:
    """The score a checkpoint is ranked by: the latest measured ``return_mean_policy`` of the
    block (mean over seeds), falling back to ``return_stochastic``; ``-inf`` when neither was."""
    for key in ("return_mean_policy", "return_stochastic"):
        if key in metrics:
            value = _latest(metrics[key])
            if not math.isnan(value):
                return value
    return -math.inf


# --------------------------------------------------------------------------- one writer per run directory


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    return True


def lock_holder(run_dir: str | os.PathLike) -> dict[str, Any] | None:
    """The live process holding ``run_dir``'s lock (``{"pid", "host", "started"}``), or ``None``
    when the directory is free or its lock is stale (its process, on this host, has ended)."""
    path = Path(run_dir) / LOCK_FILE
    try:
        holder = json.loads(path.read_text())
        pid, host = int(holder["pid"]), str(holder["host"])
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, TypeError):
        return None  # a torn lock file: its writer died while writing it
    if host == platform.node() and (pid == os.getpid() or not pid_alive(pid)):
        return None
    return holder


def check_unlocked(run_dir: str | os.PathLike) -> None:
    """``RunDirError`` (one line) when another live process writes ``run_dir``."""
    holder = lock_holder(run_dir)
    if holder is not None:
        lock = Path(run_dir) / LOCK_FILE
        raise RunDirError(
            f"run directory {str(run_dir)!r} is in use by process {holder['pid']} on {holder['host']} "
            f"(since {holder.get('started', '?')}); wait for it to finish or stop it (if that process is gone, "
            f"delete {shlex.quote(str(lock))})"
        )


class RunLock:
    """The lock that makes one process the only writer of a run directory.

    ``acquire`` creates ``.jaxpg.lock`` (process id, host, start time) atomically; a lock whose
    process is gone (same host, PID no longer running) is stale and taken over. ``release``
    removes it; it also runs at interpreter exit, so any normal or error exit frees the directory
    (a ``kill -9`` leaves a stale lock, which the next writer detects by its PID).
    """

    def __init__(self, run_dir: str | os.PathLike):
        self.path = Path(run_dir) / LOCK_FILE
        self.held = False
        self.record = json.dumps(
            {
                "pid": os.getpid(),
                "host": platform.node(),
                "started": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
            }
        )

    def acquire(self) -> dict[str, Any] | None:
        """Take the lock (``RunDirError`` when a live process holds it); returns the record of the
        stale lock it took over (``{}`` for an unreadable one), ``None`` when there was none."""
        stale = None
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                check_unlocked(self.path.parent)
                try:
                    stale = json.loads(self.path.read_text())
                except (OSError, ValueError):
                    stale = {}
                stale = stale if isinstance(stale, dict) else {}
                self.path.unlink(missing_ok=True)  # stale: its process has ended
                continue
            with os.fdopen(fd, "w") as f:
                f.write(self.record)
            self.held = True
            atexit.register(self.release)
            return stale
        check_unlocked(self.path.parent)
        raise RunDirError(f"cannot lock run directory {str(self.path.parent)!r}")

    def copy_to(self, directory: str | os.PathLike) -> None:
        """Write this lock's record into ``directory`` as well (a directory about to take the
        locked one's place, so that it is never unlocked)."""
        with open(Path(directory) / LOCK_FILE, "x") as f:
            f.write(self.record)

    def release(self) -> None:
        if self.held:
            self.held = False
            try:
                holder = json.loads(self.path.read_text())
                if int(holder.get("pid", -1)) == os.getpid():
                    self.path.unlink()
            except (OSError, ValueError):
                pass
