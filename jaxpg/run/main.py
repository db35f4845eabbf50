"""``python -m jaxpg.cli``: join the processes, check the backend, plan, execute."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

from jaxpg.run import replacing
from jaxpg.run.command_line import (
    DEFAULT_EPILOG,
    Experiment,
    Parser,
    add_distributed_flags,
    pre_parse,
    videos_requested,
)
from jaxpg.run.flags import check_backend
from jaxpg.run.planning import plan
from jaxpg.run.session import execute


def start_processes(argv: Sequence[str]) -> None:
    """``jax.distributed.initialize`` when ``argv`` or the environment name several processes;
    before anything else touches JAX's devices. ``DistributedError`` (one line) on bad settings or
    an unreachable coordinator."""
    from jaxpg.run import processes

    config = distributed_config(argv)
    if config is not None:
        processes.initialize(config)


def distributed_config(argv: Sequence[str]) -> Any:
    """The ``jaxpg.run.processes.DistributedConfig`` that ``argv`` and the environment ask for
    (``None``: one process), read before the full parse so that JAX is initialised first."""
    from jaxpg.run import processes

    pre = Parser(add_help=False)
    add_distributed_flags(pre)
    args, _ = pre.parse_known_args(argv)
    return processes.DistributedConfig.resolve(
        args.coordinator_address, args.num_processes, args.process_id, timeout_s=args.distributed_timeout
    )


def main(argv: Sequence[str] | None = None, experiment: Experiment | None = None) -> int:
    """Entry point of ``python -m jaxpg.cli`` and the experiment scripts; returns the exit status."""
    from jaxpg import video as video_lib
    from jaxpg.run import compile_cache

    experiment = experiment or Experiment(prog="python -m jaxpg.cli", epilog=DEFAULT_EPILOG)
    argv = list(sys.argv[1:] if argv is None else argv)
    if videos_requested(argv, experiment):
        video_lib.configure_gl()  # before MuJoCo is imported, and only when a video may be drawn
    compile_cache.enable()  # a second run of the same program loads it instead of compiling
    try:
        start_processes(argv)
        check_backend()
        recover_run_dir(argv)
        plan_ = plan(argv, experiment)
    except ValueError as e:  # UsageError, RunDirError, CheckpointError, Config.validate, DistributedError
        message = str(e).strip().splitlines()
        print(f"error: {message[0] if message else type(e).__name__}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"error: cannot put the run directory back in order: {e}", file=sys.stderr)
        return 2
    return execute(plan_)


def recover_run_dir(argv: Sequence[str]) -> None:
    """Before planning: put back the run that an ``--overwrite`` of the command's run directory
    (``--run-dir`` or ``--resume``) moved aside, if its process ended before the new run's first
    checkpoint, or point to it (``replacing.recover_replaced``). Process 0 alone; the others wait."""
    from jaxpg.run import processes

    pre = pre_parse(argv)
    target = pre.resume if pre.resume is not None else pre.run_dir
    if target is not None and processes.is_primary():
        for line in replacing.recover_replaced(target):
            print(line, file=sys.stderr)
    processes.barrier("jaxpg: run directory recovered")
