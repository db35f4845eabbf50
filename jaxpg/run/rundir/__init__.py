"""The run directory: its layout, ``config.json``, what ``--overwrite`` may replace, the lock, and
the interrupts that stop a run with its directory in order."""
