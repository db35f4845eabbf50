"""The registered sinks of a run (``jaxpg.run.outputs.sink``) and what a run directory may hold, derived from
them: the run's own files (``RUN_FILES``) and every registered sink's ``entries``.

``--overwrite`` (``jaxpg.run.rundir.directory``) accepts a directory holding only these; a new output is
one ``Sink`` subclass with its ``entries``, added with ``register``.
"""

from __future__ import annotations

from jaxpg.run.outputs.metrics_log import JsonlLog
from jaxpg.run.outputs.plotting import CurveHistory
from jaxpg.run.outputs.sink import Entry, Sink
from jaxpg.run.outputs.tensorboard import TensorBoardLog
from jaxpg.run.outputs.videos import Videos
from jaxpg.run.rundir.layout import CHECKPOINT_DIR, CONFIG_FILE, LOCK_FILE, PROFILE_FILE

RUN_FILES = (
    Entry(CONFIG_FILE, temporary=(CONFIG_FILE + ".tmp",)),
    Entry(CHECKPOINT_DIR, directory=True),  # Orbax's steps: checked by jaxpg.run.rundir.directory's own rules
    Entry(PROFILE_FILE, temporary=(PROFILE_FILE + ".tmp",)),
    Entry(LOCK_FILE),
)
"""What a run writes in its directory besides its sinks' outputs."""

_registered: list[type[Sink]] = [JsonlLog, TensorBoardLog, CurveHistory, Videos]


def register(sink_type: type[Sink]) -> type[Sink]:
    """Add ``sink_type`` to every later run's sinks, after those registered before (usable as a
    class decorator); registering it again changes nothing."""
    if sink_type not in _registered:
        _registered.append(sink_type)
    return sink_type


def unregister(sink_type: type[Sink]) -> None:
    """Take ``sink_type`` out of the registered sinks (a no-op when it is not there)."""
    if sink_type in _registered:
        _registered.remove(sink_type)


def registered() -> tuple[type[Sink], ...]:
    """The registered sink types, in the order they receive each block."""
    return tuple(_registered)


def _entries() -> list[Entry]:
    return [*RUN_FILES, *(entry for sink_type in _registered for entry in sink_type.entries)]


def run_entries() -> frozenset[str]:
    """Every name a run writes at the top of its directory, its temporary files included."""
    return frozenset(name for entry in _entries() for name in (entry.name, *entry.temporary))


def run_dirs() -> frozenset[str]:
    """The names of ``run_entries`` that are directories; every other one is a file."""
    return frozenset(entry.name for entry in _entries() if entry.directory)


def run_subentries() -> dict[str, tuple[str, ...]]:
    """What a run writes inside its directories, as regular expressions of whole paths relative to
    the run directory (``checkpoints/`` aside: Orbax's layout inside a step is Orbax's)."""
    return {entry.name: entry.inside for entry in _entries() if entry.directory and entry.inside}
