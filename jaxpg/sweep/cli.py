"""The command line of ``python -m jaxpg.sweep`` (docs/sweeps.md).

Example: PPO on Walker2d, two learning rates x three clip ranges, 8 seeds each::

    python -m jaxpg.sweep --task walker2d --algo ppo --preset walker2d_fast \\
        --grid lr=1e-4,3e-4 --grid clip_eps=0.1,0.2,0.3 --seeds 8 --out sweeps/walker2d

Values: ``--set FIELD=VALUE`` and ``--grid FIELD=V1,V2,...`` take numbers, ``true``/``false``,
names, or a JSON list of values (``--grid 'policy_hidden=[[64,64],[256,256]]'``); ranges are
``LOW:HIGH``. A bad spec gets one ``error:`` line and exit status 2 before anything compiles; the
same command again resumes an interrupted sweep.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from typing import Any

from jaxpg.sweep.spec import Range, SpecError, SweepSpec


def parse_value(text: str) -> Any:
    """A number, ``true``/``false`` or a JSON value; anything else as the string itself."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def split_assignment(text: str, option: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name or not value:
        raise SpecError(f"{option} takes FIELD=VALUE, got {text!r}")
    return name.strip(), value.strip()


def parse_grid(text: str) -> tuple[str, list[Any]]:
    """``FIELD=V1,V2`` or ``FIELD=[JSON list]`` -> ``(field, values)``."""
    name, value = split_assignment(text, "--grid")
    if value.startswith("["):
        values = parse_value(value)
        if not isinstance(values, list):
            raise SpecError(f"--grid {name}: cannot read {value!r} as a JSON list")
        return name, values
    return name, [parse_value(v) for v in value.split(",") if v.strip()]


def parse_range(text: str, option: str, scale: str) -> tuple[str, Range]:
    """``FIELD=LOW:HIGH`` -> ``(field, Range)``."""
    name, value = split_assignment(text, option)
    low, sep, high = value.partition(":")
    try:
        return name, Range(float(low), float(high), scale)
    except ValueError:
        raise SpecError(f"{option} {name}: expected LOW:HIGH numbers, got {value!r}") from None


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m jaxpg.sweep",
        description="Train many configurations x seeds in few compiled programs; score and report them.",
    )
    p.add_argument("--task", required=True)
    p.add_argument("--algo", required=True)
    p.add_argument("--preset", default=None, help="the base preset (python -m jaxpg.cli --list-presets)")
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", help="a base field, every run")
    p.add_argument("--grid", action="append", default=[], metavar="FIELD=V1,V2", help="swept values (all combinations)")
    p.add_argument("--uniform", action="append", default=[], metavar="FIELD=LOW:HIGH")
    p.add_argument("--log-uniform", action="append", default=[], metavar="FIELD=LOW:HIGH")
    p.add_argument("--int-range", action="append", default=[], metavar="FIELD=LOW:HIGH")
    p.add_argument("--samples", type=int, default=0, help="random configurations per grid point, from the ranges")
    p.add_argument("--sample-seed", type=int, default=0)
    p.add_argument("--seeds", type=int, default=4, help="seeds 0..N-1 of every configuration")
    p.add_argument("--first-seed", type=int, default=0)
    p.add_argument("--iterations", type=int, default=None, help="default: the preset's")
    p.add_argument("--out", required=True, help="the sweep directory (created, or resumed)")
    p.add_argument("--runs-per-chunk", type=int, default=0, help="0: as many as fit the device memory")
    p.add_argument("--episodes", type=int, default=10, help="Gymnasium episodes per run's score (0: no scoring)")
    p.add_argument("--workers", type=int, default=None, help="scoring processes (default: the cores, up to 16)")
    p.add_argument("--max-chunks", type=int, default=0, help="stop after training this many chunks (0: all)")
    p.add_argument("--max-programs", type=int, default=0, help="refuse a sweep needing more programs (0: any)")
    p.add_argument("--no-figures", action="store_true")
    p.add_argument("--coordinator-address", default=None)
    p.add_argument("--num-processes", type=int, default=None)
    p.add_argument("--process-id", type=int, default=None)
    return p


def spec_from_args(args: argparse.Namespace) -> SweepSpec:
    """The ``SweepSpec`` the parsed command line describes (``SpecError`` for malformed values)."""
    overrides = dict(split_assignment(t, "--set") for t in args.set)
    overrides = {k: parse_value(v) for k, v in overrides.items()}
    grid = dict(parse_grid(t) for t in args.grid)
    ranges = dict(parse_range(t, "--uniform", "uniform") for t in args.uniform)
    ranges.update(parse_range(t, "--log-uniform", "log") for t in args.log_uniform)
    ranges.update(parse_range(t, "--int-range", "int") for t in args.int_range)
    if args.seeds < 1:
        raise SpecError(f"--seeds must be >= 1, got {args.seeds}")
    for name in ("runs_per_chunk", "episodes", "max_chunks", "max_programs", "samples"):
        if getattr(args, name) < 0:
            raise SpecError(f"--{name.replace('_', '-')} must be >= 0, got {getattr(args, name)}")
    return SweepSpec(
        task=args.task,
        algo=args.algo,
        preset=args.preset,
        overrides=overrides,
        grid=grid,
        ranges=ranges,
        samples=args.samples,
        seeds=tuple(range(args.first_seed, args.first_seed + args.seeds)),
        iterations=args.iterations,
        sample_seed=args.sample_seed,
        max_programs=args.max_programs,
    )


def main(argv: Sequence[str] | None = None) -> int:
    args = parser().parse_args(argv)
    from jaxpg.run.command import startup
    from jaxpg.run.host import compile_cache, processes

    if argv is None:  # the process is the command's own: GPU memory on demand, as jaxpg.cli takes it
        startup.allocate_gpu_memory_on_demand()
    compile_cache.enable()  # a resumed sweep loads its programs instead of compiling them again

    try:
        spec = spec_from_args(args)
        distributed = processes.DistributedConfig.resolve(args.coordinator_address, args.num_processes, args.process_id)
        if distributed is not None:
            processes.initialize(distributed)
        from jaxpg.sweep.api import run_sweep

        result = run_sweep(
            spec,
            args.out,
            runs_per_chunk=args.runs_per_chunk,
            episodes=args.episodes,
            workers=args.workers,
            max_chunks=args.max_chunks,
            figures=not args.no_figures,
        )
    except (SpecError, processes.DistributedError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if result is not None:
        print(result.table())
        print(f"tables and figures in {args.out}")
    return 0
