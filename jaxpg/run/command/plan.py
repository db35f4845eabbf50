"""What a run will do (``Plan``, which the command line fills in) and the state it starts from."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import jax

from jaxpg import train
from jaxpg.envs import compile_options
from jaxpg.run.command.startup_times import StartupTimes
from jaxpg.run.rundir.config_io import RunConfig


@dataclasses.dataclass
class Plan:
    """A checked run: everything is known, nothing is written or compiled yet."""

    run: RunConfig
    run_dir: Path
    module: Any
    env: Any
    config: Any
    start: int = 0
    later_checkpoints: list[int] = dataclasses.field(default_factory=list)  # --from-step: the steps after start
    state: Any = None
    overwrite: bool = False
    replaced: Path | None = None  # the old run that --overwrite moved aside
    created: bool = False  # this run created its directory
    fresh: bool = False  # a new run found its directory empty, made it, or moved the old run aside
    profile: bool = False
    progress: bool | None = None
    command: list[str] = dataclasses.field(default_factory=list)
    # Stop (checkpoint written, status 0) once this many seconds have passed since the first block.
    time_limit_s: float | None = None
    # Where the command's start-up went, for the end-of-run report (None: not timed).
    startup: StartupTimes | None = None


@functools.lru_cache(maxsize=16)
def _compiled_init(module: Any, env: Any, config: Any, seeds: tuple[int, ...]) -> Any:
    """Jitted ``init`` (several seeds: ``train.init_seeds``), cached so that runs in one process
    share the compiled program."""
    if len(seeds) > 1:
        return compile_options.jit(lambda: train.init_seeds(module.init, seeds, env, config), env)
    return compile_options.jit(lambda key: module.init(key, env, config), env)


def initial_state(module: Any, env: Any, config: Any, seeds: Sequence[int]) -> Any:
    init = _compiled_init(module, env, config, tuple(seeds))
    return init() if len(seeds) > 1 else init(jax.random.PRNGKey(seeds[0]))
