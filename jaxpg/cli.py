"""``python -m jaxpg.cli``: the command line of jaxpg (``jaxpg.run.command.main``).

    python -m jaxpg.cli --env inverted_pendulum --algo npg --iterations 50
    python -m jaxpg.cli --env hopper --preset lyceum --seeds 1 2 3 5 8 --run-dir runs/hopper
    python -m jaxpg.cli --resume runs/hopper --iterations 400

The experiment scripts (``experiments/*.py``) are this command with other defaults:
``main(argv, Experiment(...))``. The host side lives in ``jaxpg.run``: flags
(``command_line``), planning (``planning``), the session (``session``).
"""

from __future__ import annotations

from jaxpg.run.command.command_line import Experiment
from jaxpg.run.command.flags import UsageError
from jaxpg.run.command.main import exit_process, main

__all__ = ["Experiment", "UsageError", "exit_process", "main"]

if __name__ == "__main__":
    exit_process(main(owns_process=True))
