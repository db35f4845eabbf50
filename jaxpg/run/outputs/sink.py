"""One protocol for a run's outputs: ``Sink``, what each declares it writes in the run directory
(``Entry``), and the block of iterations it receives (``Block``).

A sink is made for a run by ``Sink.open(plan, printer)`` (``None``: not wanted by this run), receives
every block of iterations through ``write_block`` (in ``jaxpg.run.training.callbacks``' order: before the
block's checkpoint, or after it when ``after_checkpoint``), may be given text once
(``add_text``), and is closed at the end. Its class lists the run-directory entries it writes
(``entries``): ``jaxpg.run.outputs.sinks`` derives from them what ``--overwrite`` accepts in a run
directory. The sinks of a run: ``metrics.jsonl`` (``metrics_log.JsonlLog``), TensorBoard
(``tensorboard.TensorBoardLog``), the curves (``plotting.CurveHistory``), videos
(``videos.Videos``), and the console (``console.Progress``).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np


@dataclasses.dataclass(frozen=True)
class Entry:
    """A name a run writes at the top of its directory.

    Attributes:
      name: the file's or directory's name.
      directory: whether it is a directory (else a file).
      inside: regular expressions of the whole paths (relative to the run directory) that the run
        writes inside the directory; a directory without them is checked by its own rules
        (``checkpoints/``: ``jaxpg.run.rundir.directory``).
      temporary: names of the temporary files that its atomic writes leave beside it.
    """

    name: str
    directory: bool = False
    inside: tuple[str, ...] = ()
    temporary: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class Block:
    """A block of iterations as the sinks receive it.

    Attributes:
      state: the train state after the block.
      metrics: ``update``'s metrics, ``[n]`` arrays or ``[n, num_seeds]`` with several seeds.
      first: the iteration before the block (0-based index of its first iteration).
      records: one record per iteration and seed (``metrics_log.block_records``), as
        ``metrics.jsonl`` holds them.
      steps_per_s: the block's training rate (env steps per second).
    """

    state: Any
    metrics: dict[str, np.ndarray]
    first: int
    records: list[dict[str, Any]]
    steps_per_s: float


class Sink:
    """An output of a run (module docstring). Subclasses set ``entries`` (what they write in the
    run directory) and define ``open`` and ``write_block``; ``add_text`` and ``close`` do nothing
    unless overridden."""

    entries: ClassVar[tuple[Entry, ...]] = ()
    after_checkpoint: ClassVar[bool] = False  # receives each block after its checkpoint is written

    @classmethod
    def open(cls, plan: Any, printer: Any) -> Sink | None:
        """This sink for ``plan`` (a ``jaxpg.run.command.plan.Plan``) on process 0, or ``None`` when the run
        does not want it; ``printer.write(line)`` prints a line above the progress bar
        (``console.Progress``)."""
        raise NotImplementedError

    def write_block(self, block: Block) -> None:
        raise NotImplementedError

    def add_text(self, tag: str, text: str) -> None:
        """Text written once, at a fresh run's start (the run's config)."""

    def close(self) -> None:
        pass
