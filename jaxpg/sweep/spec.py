"""What a sweep trains: a task, an algorithm, a base config (a preset plus overrides), the swept
fields (a grid and/or random draws from ranges) and the seeds; expanded into configurations and
checked before anything compiles.

``SweepSpec.expand()`` gives the ``Configuration`` list: the cartesian product of ``grid``, each
grid point combined with ``samples`` random draws from ``ranges`` (``Range``: uniform, log-uniform,
or integers), drawn from ``sample_seed`` so that the same spec always gives the same
configurations. ``check`` refuses a spec (``SpecError``, one line) for an unknown field, a value
the algorithm's ``Config.validate`` refuses, or more compiled programs than ``max_programs``
allows (a swept field that changes shapes or structure, ``jaxpg.algos.core.program_key``).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from jaxpg import algos
from jaxpg.algos import core


class SpecError(ValueError):
    """A sweep spec that cannot run; the message is one line."""


RANGE_SCALES = ("uniform", "log", "int")


@dataclasses.dataclass(frozen=True)
class Range:
    """Random values of one field: ``low`` to ``high``, ``"uniform"``, ``"log"`` (log-uniform,
    both bounds > 0) or ``"int"`` (uniform integers, both bounds included)."""

    low: float
    high: float
    scale: str = "uniform"

    def draw(self, rng: np.random.Generator, count: int) -> list[Any]:
        """``count`` values from ``rng``."""
        if self.scale == "log":
            return [float(v) for v in np.exp(rng.uniform(math.log(self.low), math.log(self.high), count))]
        if self.scale == "int":
            return [int(v) for v in rng.integers(int(self.low), int(self.high) + 1, count)]
        return [float(v) for v in rng.uniform(self.low, self.high, count)]


@dataclasses.dataclass(frozen=True)
class Configuration:
    """One point of a sweep: ``index`` (0-based, stable for a spec), the swept ``values`` and the
    full ``config`` (the algorithm's ``Config``)."""

    index: int
    values: dict[str, Any]
    config: Any

    @property
    def label(self) -> str:
        """``field=value`` pairs, e.g. ``lr=0.0003 clip_eps=0.2`` (``base`` when nothing is swept)."""
        return " ".join(f"{k}={_short(v)}" for k, v in self.values.items()) or "base"


def _short(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


@dataclasses.dataclass(frozen=True)
class SweepSpec:
    """A sweep (module docstring).

    Attributes:
      task, algo: ``jaxpg.envs`` and ``jaxpg.algos`` names.
      preset: the base preset (``jaxpg.algos.preset``), or ``None`` for the ``Config`` defaults.
      overrides: fields set on top of the preset for every configuration.
      grid: field -> values; every combination is a configuration.
      ranges: field -> ``Range``; ``samples`` random draws per grid point.
      samples: random draws from ``ranges`` (required > 0 when ``ranges`` is given).
      seeds: the training seeds of every configuration.
      iterations: iterations of every run (``None``: the preset's, else 100).
      sample_seed: seed of the random draws.
      env_kwargs: task options (``jaxpg.envs.make``); the preset's own are added.
      max_programs: refuse a spec that needs more compiled programs (0: no limit).
    """

    task: str
    algo: str
    preset: str | None = None
    overrides: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    grid: Mapping[str, Sequence[Any]] = dataclasses.field(default_factory=dict)
    ranges: Mapping[str, Range] = dataclasses.field(default_factory=dict)
    samples: int = 0
    seeds: Sequence[int] = (0,)
    iterations: int | None = None
    sample_seed: int = 0
    env_kwargs: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    max_programs: int = 0

    def module(self) -> Any:
        try:
            return algos.get(self.algo)
        except ValueError as e:
            raise SpecError(str(e)) from None

    def base_values(self) -> dict[str, Any]:
        """The preset's fields with ``overrides`` on top."""
        base = {}
        if self.preset is not None:
            try:
                base = algos.preset(self.algo, self.preset, self.task)
            except ValueError as e:
                raise SpecError(str(e)) from None
        return {**base, **self.overrides}

    def all_env_kwargs(self) -> dict[str, Any]:
        """The preset's task options with ``env_kwargs`` on top."""
        preset = algos.preset_env_kwargs(self.algo, self.preset) if self.preset else {}
        return {**preset, **self.env_kwargs}

    def total_iterations(self) -> int:
        if self.iterations is not None:
            return self.iterations
        preset = algos.preset_iterations(self.algo, self.preset) if self.preset else None
        return preset or 100

    def swept_values(self) -> list[dict[str, Any]]:
        """The swept field values of each configuration, in order (grid-major, then draws)."""
        names = list(self.grid)
        points = [dict(zip(names, combo, strict=True)) for combo in itertools.product(*self.grid.values())]
        if not self.ranges:
            return points
        rng = np.random.default_rng(self.sample_seed)
        out = []
        for point in points:
            draws = {name: r.draw(rng, self.samples) for name, r in self.ranges.items()}
            out.extend({**point, **{name: draws[name][i] for name in self.ranges}} for i in range(self.samples))
        return out

    def expand(self, env: Any = None) -> list[Configuration]:
        """Every configuration, validated against ``env`` (default: the task's) and checked
        (``check``); ``SpecError`` otherwise."""
        module = self.module()
        self._check_shape()
        if env is None:
            env = self.make_env()
        fields = {f.name for f in dataclasses.fields(module.Config)}
        unused = set(getattr(module.Config, "UNUSED_FIELDS", ()))
        base = self.base_values()
        for name in [*base, *self.grid, *self.ranges]:
            if name not in fields or name in unused:
                raise SpecError(f"unknown field {name!r} of {self.algo}'s Config")
        for name in set(self.grid) & set(self.ranges):
            raise SpecError(f"field {name!r} is both in the grid and in the ranges")
        base = {name: _typed(module.Config, name, value) for name, value in base.items()}
        configurations = []
        for index, values in enumerate(self.swept_values()):
            typed = {name: _typed(module.Config, name, value) for name, value in values.items()}
            try:
                config = module.Config(**{**base, **typed})
                config.validate(env)
            except (TypeError, ValueError) as e:
                label = " ".join(f"{k}={_short(v)}" for k, v in typed.items()) or "base"
                raise SpecError(f"configuration {index} ({label}): {e}") from None
            configurations.append(Configuration(index, typed, config))
        programs = {core.program_key(c.config) for c in configurations}
        if self.max_programs and len(programs) > self.max_programs:
            traced = core.traced_fields(module.Config)
            splitting = sorted(n for n in values if n not in traced or _switches(n, configurations))
            raise SpecError(
                f"the sweep needs {len(programs)} compiled programs (max_programs {self.max_programs}): "
                f"{', '.join(splitting) or 'a field'} change shapes or structure and cannot vary in one program"
            )
        return configurations

    def _check_shape(self) -> None:
        if self.ranges and self.samples < 1:
            raise SpecError("ranges need samples >= 1 (random configurations per grid point)")
        if not self.ranges and self.samples:
            raise SpecError("samples needs ranges to draw from")
        if not self.seeds or len(set(self.seeds)) != len(self.seeds):
            raise SpecError(f"seeds must be distinct, at least one, got {list(self.seeds)}")
        for name, values in self.grid.items():
            if not list(values):
                raise SpecError(f"grid field {name!r} has no values")
        for name, r in self.ranges.items():
            if r.scale not in RANGE_SCALES:
                raise SpecError(f"range of {name!r}: scale must be one of {', '.join(RANGE_SCALES)}, got {r.scale!r}")
            if not r.low <= r.high or (r.scale == "log" and r.low <= 0):
                raise SpecError(f"range of {name!r}: need low <= high (and low > 0 for log), got {r.low}:{r.high}")
        if self.total_iterations() < 1:
            raise SpecError(f"iterations must be >= 1, got {self.total_iterations()}")

    def make_env(self) -> Any:
        from jaxpg import envs

        try:
            return envs.make_shared(self.task, **self.all_env_kwargs())
        except (ValueError, TypeError) as e:
            raise SpecError(str(e)) from None

    def to_json(self) -> dict[str, Any]:
        """A JSON-able description (what a sweep directory records, and compares on resume)."""
        out = dataclasses.asdict(self)
        out["ranges"] = {k: dataclasses.asdict(v) for k, v in self.ranges.items()}
        out["grid"] = {k: list(v) for k, v in self.grid.items()}
        out["seeds"] = list(self.seeds)
        out["overrides"] = dict(self.overrides)
        out["env_kwargs"] = dict(self.env_kwargs)
        return out


def _switches(name: str, configurations: list[Configuration]) -> bool:
    """Whether the traced field ``name`` is on in some configurations and off in others."""
    states = {dict(core.hparams.switch_states(c.config)).get(name) for c in configurations}
    return len(states) > 1


def _typed(config_cls: type, name: str, value: Any) -> Any:
    """``value`` in the type of ``config_cls``'s field ``name`` (``jaxpg.run.rundir.coercion.coerce``: a
    whole float for an int field becomes an int, an int for a float field a float); ``SpecError``
    otherwise."""
    from jaxpg.run.rundir import config_io

    try:
        return config_io.coerce(config_io.field_types(config_cls)[name], value)
    except ValueError as e:
        raise SpecError(f"field {name!r} {e}") from None
