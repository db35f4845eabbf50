"""Training a sweep: every (configuration, seed) run, as few compiled programs as the configs'
structures allow, in chunks of runs that fit the devices' memory, sharded over every device.

Runs whose configs share ``core.program_key`` train in one program: ``vmap`` over runs of the
algorithm's ``update``, each run reading its numbers from ``TrainState.hparams``
(``core.with_hyperparameters``), scanned over a block of iterations. The runs axis is split over
a 1-D mesh of ``jax.devices()`` (every device of every process after
``jaxpg.run.host.processes.initialize``); jit's partitioner (GSPMD, ``jaxpg.mesh.use_gspmd_partitioner``)
runs each device's runs there, and ``jaxpg.mesh.put_global`` / ``host_copy`` move the arrays.

Chunk size (runs per program call): the program's runs, rounded up to a multiple of the devices,
halved until XLA's own memory analysis of the compiled training block (arguments + outputs +
temporaries, per device) fits in ``MEMORY_SHARE`` of the free memory of the smallest device
(``jaxpg.run.host.memory.available_memory``; on the CPU the host's, shared by its devices); or the
number given. Padding runs repeat the chunk's last run and are dropped.

What a chunk leaves in the sweep directory (``SweepStore``) is written after it trained, so an
interrupted sweep resumes with the runs no chunk finished.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax.experimental import multihost_utils
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from jaxpg import mesh as mesh_lib
from jaxpg.algos import core
from jaxpg.envs import compile_options
from jaxpg.sweep.spec import Configuration

RUN_AXIS = "runs"
MEMORY_SHARE = 0.8  # of the free device memory a chunk's program may take
CURVE_METRICS = ("return_stochastic", "episode_length", "kl", "update_rejected")


@dataclasses.dataclass(frozen=True)
class Run:
    """One training run: ``index`` (stable: ``configuration * num_seeds + seed position``), its
    ``configuration`` index and its training ``seed``."""

    index: int
    configuration: int
    seed: int


def all_runs(configurations: list[Configuration], seeds: list[int]) -> list[Run]:
    """Every (configuration, seed) run, configuration-major."""
    return [Run(c.index * len(seeds) + i, c.index, seed) for c in configurations for i, seed in enumerate(seeds)]


def programs(configurations: list[Configuration]) -> list[list[Configuration]]:
    """The configurations grouped by compiled program (``core.program_key``), in order of first
    appearance."""
    groups: dict[Any, list[Configuration]] = {}
    for c in configurations:
        groups.setdefault(core.program_key(c.config), []).append(c)
    return list(groups.values())


def iteration_block(iterations: int) -> int:
    """Iterations per compiled call: the largest divisor of ``iterations`` that is at most a tenth
    of it (at least 1), so that every call runs the same program and the curves get ~10 or more
    wall-clock points."""
    limit = max(1, iterations // 10)
    return max(d for d in range(1, limit + 1) if iterations % d == 0)


def run_mesh() -> Mesh:
    """A 1-D mesh with the axis ``RUN_AXIS`` over every device of every process."""
    devices = jax.devices()
    if len(devices) > 1:
        mesh_lib.use_gspmd_partitioner()
    return Mesh(np.array(devices), (RUN_AXIS,))


@dataclasses.dataclass
class Program:
    """The compiled functions of one program (one config structure) at one chunk size.

    ``init(keys [R, 2], hparams {name: [R]}) -> states [R, ...]``;
    ``block(states) -> (states, {metric: [R, block]})`` (the states are donated)."""

    init: Callable
    block: Callable
    runs: int
    bytes_per_device: int


def build_program(module: Any, env: Any, config: Any, runs: int, block: int, mesh: Mesh) -> Program:
    """Compile ``module``'s training for ``runs`` runs of configs shaped like ``config`` (its
    traced numbers come from the runs' hparams), ``block`` iterations a call, on ``mesh``."""
    sharding = NamedSharding(mesh, PartitionSpec(RUN_AXIS))

    def init_one(key: jax.Array, hparams: dict[str, jax.Array]) -> Any:
        return core.with_hyperparameters(module.init(key, env, config), hparams)

    def block_one(ts: Any) -> tuple[Any, dict[str, jax.Array]]:
        ts, metrics = jax.lax.scan(lambda s, _: module.update(s), ts, None, length=block)
        return ts, {k: metrics[k] for k in CURVE_METRICS if k in metrics}

    init = compile_options.jit(jax.vmap(init_one), env, out_shardings=sharding)
    train = compile_options.jit(jax.vmap(block_one), env, out_shardings=sharding, donate_argnums=0)
    keys = jax.ShapeDtypeStruct((runs, 2), jnp.uint32, sharding=sharding)
    hparams = {
        k: jax.ShapeDtypeStruct((runs,), v.dtype, sharding=sharding) for k, v in core.hyperparameters(config).items()
    }
    states = jax.eval_shape(init, keys, hparams)
    states = jax.tree.map(lambda s: jax.ShapeDtypeStruct(s.shape, s.dtype, sharding=sharding), states)
    compiled = train.lower(states).compile()
    return Program(init, compiled, runs, program_bytes(compiled))  # init compiles at its first call


def program_bytes(compiled: Any) -> int:
    """Per-device bytes XLA's memory analysis gives a compiled program (arguments + outputs +
    temporaries, less what outputs alias of donated arguments); 0 where the backend gives none."""
    analysis = compiled.memory_analysis()
    if analysis is None:
        return 0
    total = analysis.argument_size_in_bytes + analysis.output_size_in_bytes + analysis.temp_size_in_bytes
    return int(total - analysis.alias_size_in_bytes)


def round_up(n: int, multiple: int) -> int:
    return -(-n // multiple) * multiple


def fitting_program(
    module: Any, env: Any, config: Any, wanted: int, block: int, mesh: Mesh, runs_per_chunk: int = 0
) -> Program:
    """The program for a chunk: ``runs_per_chunk`` runs when given (rounded up to the devices),
    else ``wanted`` runs halved until its memory analysis fits (module docstring)."""
    from jaxpg.run.host.memory import available_memory

    devices = mesh.devices.size
    if runs_per_chunk:
        return build_program(module, env, config, round_up(runs_per_chunk, devices), block, mesh)
    memory = available_memory()
    budget = None
    if memory is not None:
        available, _, shared = memory
        budget = MEMORY_SHARE * (available / len(jax.local_devices()) if shared else available)
    runs = round_up(wanted, devices)
    while True:
        program = build_program(module, env, config, runs, block, mesh)
        fits = budget is None or program.bytes_per_device <= budget
        # every process must choose the same size: the smallest verdict wins
        fits = bool(np.min(multihost_utils.process_allgather(np.array([fits]))))
        if fits or runs <= devices:
            return program
        runs = round_up(max(devices, runs // 2), devices)


def stacked_hparams(runs: list[Run], configurations: dict[int, Configuration]) -> dict[str, np.ndarray]:
    """``{name: [R]}`` of the runs' hyperparameters (``core.hyperparameters``), on the host."""
    per_run = [core.hyperparameters(configurations[r.configuration].config) for r in runs]
    return {k: np.stack([np.asarray(h[k]) for h in per_run]) for k in per_run[0]}


@dataclasses.dataclass
class ChunkResult:
    """What one chunk produced, on the host: ``curves`` ``{metric: [R, iterations]}``,
    ``wall_s`` ``[blocks]`` seconds since the chunk's first block started at each block's end,
    ``params`` and ``obs_stats`` (lists of ``[R, ...]`` leaves of the final policies),
    ``compile_s`` and ``train_s``."""

    runs: list[Run]
    curves: dict[str, np.ndarray]
    wall_s: np.ndarray
    block: int
    params: list[np.ndarray]
    obs_stats: list[np.ndarray]
    compile_s: float
    train_s: float


def train_chunk(
    program: Program,
    module: Any,
    runs: list[Run],
    configurations: dict[int, Configuration],
    iterations: int,
    block: int,
    mesh: Mesh,
    compile_s: float = 0.0,
) -> ChunkResult:
    """Train ``runs`` (at most ``program.runs``; padded with the last) for ``iterations``."""
    padded = runs + [runs[-1]] * (program.runs - len(runs))
    sharding = NamedSharding(mesh, PartitionSpec(RUN_AXIS))
    keys = np.stack([np.asarray(jax.random.PRNGKey(r.seed)) for r in padded])
    hparams = stacked_hparams(padded, configurations)
    keys, hparams = mesh_lib.put_global((keys, hparams), jax.tree.map(lambda _: sharding, (keys, hparams)))
    start = time.perf_counter()
    states = program.init(keys, hparams)
    curves: dict[str, list[np.ndarray]] = {}
    wall = []
    for _ in range(iterations // block):
        states, metrics = program.block(states)
        metrics = mesh_lib.host_copy(metrics)
        for k, v in metrics.items():
            curves.setdefault(k, []).append(v)
        wall.append(time.perf_counter() - start)
    train_s = time.perf_counter() - start
    params, obs_stats = mesh_lib.host_copy((states.params, states.obs_stats))
    n = len(runs)
    return ChunkResult(
        runs=runs,
        curves={k: np.concatenate(v, axis=1)[:n] for k, v in curves.items()},
        wall_s=np.asarray(wall),
        block=block,
        params=[x[:n] for x in jax.tree.leaves(params)],
        obs_stats=[x[:n] for x in jax.tree.leaves(obs_stats)],
        compile_s=compile_s,
        train_s=train_s,
    )


def chunks_of(runs: list[Run], size: int) -> list[list[Run]]:
    """``runs`` cut into consecutive chunks of at most ``size``."""
    return [runs[i : i + size] for i in range(0, len(runs), size)]


def seconds_per_run(results: list[ChunkResult]) -> float:
    """Training seconds (no compilation) per run over ``results``."""
    runs = sum(len(r.runs) for r in results)
    return math.fsum(r.train_s for r in results) / max(runs, 1)
