"""The flags a command reads before its full parse (``PreFlags``), read once.

The full parser has a flag per field of the algorithm's ``Config``, so it can only be built once
the algorithm is known (``--algo``, or the run that ``--resume`` continues). Some flags are needed
earlier still: the GL backend is chosen before MuJoCo is imported, JAX joins the other processes
before anything touches a device, and a run directory left half replaced is put back before
planning reads it. ``parse_pre_flags`` reads all of them in one pass; the full parse
(``planning.plan``) reads them again with the rest and reports what is wrong with any.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from jaxpg.run.command.command_line import Experiment, Parser, add_distributed_flags


@dataclasses.dataclass(frozen=True)
class PreFlags:
    """What a command asks for before its full parse (``None``: not given).

    Attributes:
      algo, preset, impl: the flags of those names.
      resume: the run directory ``--resume`` continues; run_dir: ``--run-dir``.
      videos: whether the command may draw videos: ``--video-every`` > 0 (given, or the
        experiment's default) or a ``--resume``, whose run may have asked for them.
      coordinator_address, num_processes, process_id, distributed_timeout: how this process joins
        the others (``jaxpg.run.host.processes.DistributedConfig.resolve``).
    """

    algo: str | None = None
    preset: str | None = None
    impl: str | None = None
    resume: str | None = None
    run_dir: str | None = None
    videos: bool = False
    coordinator_address: str | None = None
    num_processes: int | None = None
    process_id: int | None = None
    distributed_timeout: int = 60

    @property
    def target(self) -> str | None:
        """The run directory the command writes: the one it resumes, else ``--run-dir``."""
        return self.resume if self.resume is not None else self.run_dir


def parse_pre_flags(argv: Sequence[str], experiment: Experiment) -> PreFlags:
    """The ``PreFlags`` of ``argv``; every other flag is left to the full parse.

    Abbreviations count as in the full parser (``--video 5``): these flags are a subset of its
    flags, so a prefix that names one flag there names the same one here. A missing value or a
    bad number of these flags is the full parser's ``UsageError``; a ``--video-every`` that is not
    a number means no videos here and is reported by the full parse.
    """
    parser = Parser(add_help=False)
    parser.add_argument("--algo")
    parser.add_argument("--preset")
    parser.add_argument("--resume")
    parser.add_argument("--run-dir")
    parser.add_argument("--impl")
    parser.add_argument("--video-every")
    add_distributed_flags(parser)
    args, _ = parser.parse_known_args(list(argv))
    try:
        video_every = experiment.video_every if args.video_every is None else int(args.video_every)
    except ValueError:
        video_every = 0
    return PreFlags(
        algo=args.algo,
        preset=args.preset,
        impl=args.impl,
        resume=args.resume,
        run_dir=args.run_dir,
        videos=args.resume is not None or video_every > 0,
        coordinator_address=args.coordinator_address,
        num_processes=args.num_processes,
        process_id=args.process_id,
        distributed_timeout=args.distributed_timeout,
    )
