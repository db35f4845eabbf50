"""A run's file writing off the training loop's path: one background thread runs host jobs in the
order they were handed in, while the main thread has already started the next block.

Only work that touches no device belongs here: ``metrics.jsonl`` and TensorBoard records built from
NumPy metrics, ``curves.png`` drawn from ``metrics.jsonl``. (With MuJoCo Warp nothing may compile
or launch on the GPU beside a running program, and device transfers stay on the main thread.)
Checkpoints stay on the main thread too; ``jaxpg.run.callbacks.Checkpoints`` waits for the jobs
before each one, so the metrics of every checkpointed iteration are on disk before its checkpoint.

    work = HostWork()
    work.submit(writer.write, records)             # returns at once; an OSError comes back ...
    work.wait()                                    # ... here, or at the next submit
    work.submit(draw_curves, checked=False)        # a job that reports its own errors
    work.close()                                   # every job done, the thread gone
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any


class HostWork:
    """Host jobs run in order on one background thread (``background=False``: at once, on the
    calling thread, as a run without this class would).

    A job is ``checked`` when its error matters to the run (a metrics file that cannot be written):
    the error is raised on the calling thread by the next ``submit``, ``raise_errors`` or ``wait``.
    An unchecked job (drawing curves, whose failure is a warning line) handles its own errors.
    """

    # Not a daemon thread's pool: the interpreter's exit (and ``jaxpg.run.main.exit_process``, which
    # runs the exit handlers) waits for its jobs, so a file being written is never cut short.

    def __init__(self, background: bool = True) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="jaxpg-host-work") if background else None
        self._checked: list[Future] = []

    def submit(self, job: Callable[..., Any], *args: Any, checked: bool = True) -> None:
        """Queue ``job(*args)`` behind the jobs handed in before it (after ``close``: run it at once).
        A checked job first raises the error of any earlier checked job that has failed."""
        if checked:
            self.raise_errors()
        if self._pool is None:
            job(*args)
            return
        future = self._pool.submit(job, *args)
        if checked:
            self._checked.append(future)

    def raise_errors(self) -> None:
        """Raise the error of the earliest finished checked job that failed, without waiting."""
        while self._checked and self._checked[0].done():
            self._checked.pop(0).result()

    def wait(self) -> None:
        """Block until every job handed in so far has run; raise the first checked job's error."""
        if self._pool is None:
            return
        self._pool.submit(lambda: None).result()  # one thread, first in first out: the others have run
        checked, self._checked = self._checked, []
        for future in checked:
            future.result()

    def close(self) -> None:
        """Let every job handed in run to its end, then stop the thread. Errors of checked jobs that
        ``wait`` did not raise are dropped: call ``wait`` first where they matter."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
        self._checked = []
