"""``python -m jaxpg.cli``: start, plan, execute.

The command goes down from ``main`` three times and comes back up in between twice:
``startup.start`` reads the flags needed first (``PreFlags``) and prepares the process (GL
backend, compilation cache, several processes, the device, a run directory left half replaced),
``planning.plan`` parses the whole command and checks it into a ``Plan`` (nothing written or
compiled), ``session.execute`` runs it.
"""

from __future__ import annotations

import atexit
import os
import sys
import threading
from collections.abc import Sequence
from typing import NoReturn

from jaxpg.run.command import planning, startup
from jaxpg.run.command.command_line import DEFAULT_EPILOG, Experiment
from jaxpg.run.rundir import config_io
from jaxpg.run.training import session


def main(argv: Sequence[str] | None = None, experiment: Experiment | None = None, owns_process: bool = False) -> int:
    """Entry point of ``python -m jaxpg.cli`` and the experiment scripts; returns the exit status.

    ``owns_process``: nothing but this command will run in the process (the scripts' own call), so
    process-wide choices made for it alone are safe (``jaxpg.run.command.startup.start``)."""
    experiment = experiment or Experiment(prog="python -m jaxpg.cli", epilog=DEFAULT_EPILOG)
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        pre = startup.start(argv, experiment, owns_process)
        plan_ = planning.plan(argv, experiment, pre)
    except ValueError as e:  # UsageError, RunDirError, CheckpointError, Config.validate, DistributedError
        for line in config_io.error_lines(e):  # one line, or one per bad value of a config.json
            print(f"error: {line}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"error: cannot put the run directory back in order: {e}", file=sys.stderr)
        return 2
    return session.execute(plan_)


def exit_process(status: int) -> NoReturn:
    """End the process with ``status`` after ``main`` has returned, as the interpreter would but
    without tearing down its thousands of modules and objects one by one (a visible part of a
    CPU run's exit; the scripts' last line).

    What the interpreter's own exit does first is done here too, in its order: wait for the
    threads that are not daemons, run the ``atexit`` handlers (JAX's, Orbax's, the run lock's),
    flush the standard streams. Every file jaxpg writes is closed before ``main`` returns.
    """
    for thread in threading.enumerate():
        if thread is not threading.current_thread() and not thread.daemon:
            thread.join()
    atexit._run_exitfuncs()  # noqa: SLF001 - the handlers the interpreter's exit would run
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed or broken pipe: nothing more can be written
            pass
    os._exit(status)
