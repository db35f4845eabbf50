"""What a command does first, before it plans: choose MuJoCo's GL backend when it may draw a video,
turn the compilation cache on, join the other processes, check that JAX has a device, and put
back a run directory that a killed ``--overwrite`` left moved aside (``start``)."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

from jaxpg.run import replacing
from jaxpg.run.command_line import Experiment, Parser, add_distributed_flags, pre_parse, videos_requested
from jaxpg.run.flags import check_backend


def start(argv: Sequence[str], experiment: Experiment) -> None:
    """Prepare this process for the command ``argv``, in the order each step needs: the GL backend
    before MuJoCo is imported, the cache before the first compilation, ``jax.distributed`` before
    anything touches JAX's devices, the run directory's recovery before planning reads it.
    Raises ``ValueError`` (one line) on bad distributed settings or when JAX has no device, and
    ``OSError`` when the run directory cannot be put back in order."""
    from jaxpg import video as video_lib
    from jaxpg.run import compile_cache

    if videos_requested(argv, experiment):
        video_lib.configure_gl()  # before MuJoCo is imported, and only when a video may be drawn
    compile_cache.enable()  # a second run of the same program loads it instead of compiling
    start_processes(argv)
    check_backend()
    recover_run_dir(argv)


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
