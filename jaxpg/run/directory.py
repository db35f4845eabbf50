"""What a run directory holds: a jaxpg run (``check_replaceable``) or something else."""

from __future__ import annotations

import os
from pathlib import Path

from jaxpg.run.config_io import RunConfig
from jaxpg.run.layout import CONFIG_FILE, RUN_ENTRIES, RunDirError


def foreign_entries(run_dir: str | os.PathLike) -> list[str]:
    """The names at the top of ``run_dir`` that a jaxpg run does not write (``RUN_ENTRIES``), sorted."""
    return sorted(name for name in os.listdir(run_dir) if name not in RUN_ENTRIES)


def check_replaceable(run_dir: str | os.PathLike, shown: str | os.PathLike | None = None) -> None:
    """``RunDirError`` (one line) unless ``run_dir`` is a jaxpg run that ``--overwrite`` may
    replace: its ``config.json`` reads as a ``RunConfig`` and it holds nothing else than what a
    run writes (``RUN_ENTRIES``). ``shown``: the name to print (default ``run_dir``)."""
    name = str(run_dir if shown is None else shown)
    if not (Path(run_dir) / CONFIG_FILE).is_file():
        raise RunDirError(f"refusing to --overwrite {name!r}: it is not a jaxpg run directory (no {CONFIG_FILE})")
    try:
        RunConfig.load(run_dir)
    except RunDirError as e:
        raise RunDirError(f"refusing to --overwrite {name!r}: it is not a jaxpg run directory ({e})") from None
    foreign = foreign_entries(run_dir)
    if foreign:
        listed = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
        raise RunDirError(
            f"refusing to --overwrite {name!r}: besides a jaxpg run it holds {listed}, which a run does not write; "
            "move them out or choose another --run-dir"
        )
