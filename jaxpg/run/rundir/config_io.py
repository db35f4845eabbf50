"""``config.json``: the ``RunConfig`` of a run (task, algorithm, full ``Config``, seeds) and the
type coercion that reads a ``Config`` back from JSON or from flags."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import types
import typing
from pathlib import Path
from typing import Any

from jaxpg import algos
from jaxpg.run.rundir.coercion import coerce, strip_optional  # noqa: F401 - strip_optional: read from here too
from jaxpg.run.rundir.layout import (
    CONFIG_FILE,
    FORMAT_VERSION,
    MAX_SEED,
    RunDirError,
    _jsonable,
    check_path,
    write_json_atomic,
)

SCHEDULE_MINIMUMS = {"iterations": 1, "log_every": 1, "checkpoint_every": 0, "keep_checkpoints": 1, "video_every": 0}
"""The smallest value of each of a run's schedule fields, in ``config.json`` as on the command
line (``--iterations`` of a new run, ``--log-every``, ``--checkpoint-every``,
``--keep-checkpoints``, ``--video-every``)."""


def schedule_problems(values: dict[str, Any], prefix: str = "") -> list[str]:
    """One line for each schedule field of ``values`` below its minimum (``SCHEDULE_MINIMUMS``)."""
    return [
        f"{prefix}{name} must be >= {low}, got {values[name]}"
        for name, low in SCHEDULE_MINIMUMS.items()
        if isinstance(values.get(name), int) and values[name] < low
    ]


class ConfigProblems(RunDirError):
    """A ``config.json`` with one or more bad values: ``problems`` holds one line for each (the
    command line prints each as an ``error:`` line); the message joins them on one line."""

    def __init__(self, problems: list[str]):
        super().__init__("; ".join(problems))
        self.problems = list(problems)


def error_lines(error: BaseException) -> list[str]:
    """The lines an error is reported in: one per bad value of a ``ConfigProblems``, else the
    first line of its message (or its type's name)."""
    if isinstance(error, ConfigProblems):
        return error.problems
    lines = str(error).strip().splitlines()
    return lines[:1] or [type(error).__name__]


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
        return algos.get(self.algo)

    def algo_config(self) -> Any:
        """The algorithm's ``Config`` with the saved field values."""
        return config_from_dict(self.algo_module().Config, self.config)

    def make_env(self) -> Any:
        """The run's env (``jaxpg.envs.make_shared``: one object per task and arguments);
        ``RunDirError`` (one line) for an unknown task or an ``env_kwargs`` entry the task does
        not take or of the wrong type (``check_env_kwargs``)."""
        from jaxpg import envs  # here: python -m jaxpg.run.outputs.plotting reads config.json without JAX

        self.check_env_kwargs()
        return envs.make_shared(self.task, **self.env_kwargs)

    def check_env_kwargs(self) -> None:
        """``ConfigProblems`` for an unknown task, or for each ``env_kwargs`` entry its task does
        not take or of the wrong type: the task options by the rules of ``--env-kwargs``
        (``jaxpg.run.command.task_options.check_options``), the simulation settings by their flags'."""
        from jaxpg import envs
        from jaxpg.run.command import task_options

        where = f"{CONFIG_FILE}: env_kwargs"
        if self.task not in envs.names():
            raise ConfigProblems([f"{CONFIG_FILE}: task {self.task!r} is not a jaxpg task"])
        settings = {
            "fidelity": str,
            "impl": str,
            "max_episode_steps": int | None,
            "action_scaling": bool,
            "batch": int,
            **{name: int for name in task_options.BUFFER_SIZES},
        }
        problems = []
        for name, value in self.env_kwargs.items():
            try:
                if name in settings:
                    coerce(settings[name], value)
                else:
                    task_options.check_options(self.task, {name: value})
            except ValueError as e:
                problems.append(f"{where}: {e}" if name not in settings else f"{where}: {name} {e}")
        steps = self.env_kwargs.get("max_episode_steps")
        if isinstance(steps, int) and not isinstance(steps, bool) and steps < 1:
            problems.append(f"{where}: max_episode_steps must be >= 1, got {steps}")
        if problems:
            raise ConfigProblems(problems)

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
        if isinstance(data["format"], bool) or data["format"] < 1:
            raise RunDirError(f"{path}: format must be an integer >= 1, got {json.dumps(data['format'])}")
        if data["format"] > FORMAT_VERSION:
            raise RunDirError(f"{path} was written by a newer jaxpg (format {data['format']})")
        types_ = field_types(cls)
        values, problems = {}, []
        unknown = sorted(set(data) - set(types_) - {"format"})
        if unknown:
            problems.append(f"{path}: unknown key{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}")
        for name, value in data.items():
            if name not in types_:
                continue
            try:
                values[name] = coerce(types_[name], value)
            except ValueError as e:
                problems.append(f"{path}: {name} {e}")
        missing = [f.name for f in dataclasses.fields(cls) if f.name not in data and _no_default(f)]
        if missing:
            problems.append(f"{path} lacks {', '.join(missing)}")
        seeds = values.get("seeds")
        if seeds is not None and (not seeds or len(set(seeds)) != len(seeds)):
            problems.append(f"{path}: seeds must be distinct integers, at least one, got {seeds}")
        bad = [s for s in seeds or () if not 0 <= s <= MAX_SEED]
        if bad:
            problems.append(f"{path}: seeds must be integers in [0, {MAX_SEED}], got {bad[0]}")
        problems += schedule_problems(values, prefix=f"{path}: ")
        if problems:
            raise ConfigProblems(problems)
        # JSON has no tuples: a task option such as healthy_z_range comes back as a list.
        values["env_kwargs"] = {k: _as_tuples(v) for k, v in values.get("env_kwargs", {}).items()}
        return cls(**values)


def _as_tuples(value: Any) -> Any:
    """``value`` with every list, nested too, as a tuple (what the env constructors take)."""
    return tuple(_as_tuples(v) for v in value) if isinstance(value, list) else value


def _no_default(field: dataclasses.Field) -> bool:
    return field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING


def _resolve_hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def field_types(cls: type) -> dict[str, Any]:
    """``{field name: resolved type}`` of a config dataclass."""
    hints = _resolve_hints(cls)
    return {f.name: hints.get(f.name, Any) for f in dataclasses.fields(cls)}


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
