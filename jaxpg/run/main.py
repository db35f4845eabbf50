"""``python -m jaxpg.cli``: start, plan, execute.

The command goes down from ``main`` three times and comes back up in between twice:
``startup.start`` reads the flags needed first (``PreFlags``) and prepares the process (GL
backend, compilation cache, several processes, the device, a run directory left half replaced),
``planning.plan`` parses the whole command and checks it into a ``Plan`` (nothing written or
compiled), ``session.execute`` runs it.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from jaxpg.run import planning, session, startup
from jaxpg.run.command_line import DEFAULT_EPILOG, Experiment


def main(argv: Sequence[str] | None = None, experiment: Experiment | None = None) -> int:
    """Entry point of ``python -m jaxpg.cli`` and the experiment scripts; returns the exit status."""
    experiment = experiment or Experiment(prog="python -m jaxpg.cli", epilog=DEFAULT_EPILOG)
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        pre = startup.start(argv, experiment)
        plan_ = planning.plan(argv, experiment, pre)
    except ValueError as e:  # UsageError, RunDirError, CheckpointError, Config.validate, DistributedError
        message = str(e).strip().splitlines()
        print(f"error: {message[0] if message else type(e).__name__}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"error: cannot put the run directory back in order: {e}", file=sys.stderr)
        return 2
    return session.execute(plan_)
