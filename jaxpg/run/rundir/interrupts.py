"""SIGINT and SIGTERM during a run: finish the compiled call, checkpoint, exit with 130 / 143."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from typing import Any

import jax


class Stop(Exception):
    """Raised by the callbacks after an interrupt, once the current compiled call has finished and
    its checkpoint is written."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class TimeUp(Exception):
    """Raised by the callbacks when ``Plan.time_limit_s`` has passed, once the block's checkpoint
    is written."""


class StopAtOnce(KeyboardInterrupt):
    """The ``KeyboardInterrupt`` that ``Interrupts`` raises to stop at once.

    A subclass, not ``KeyboardInterrupt`` itself: CPython remembers a bare ``KeyboardInterrupt``
    that passes through code run by its C API (``PyRun_*``, as some imports are), and at exit
    then kills the process by SIGINT (status -2) even though the run caught the interrupt and
    returned 130. It compares the exception's exact type, so a subclass leaves the exit status
    to the run.
    """


class Interrupts:
    """SIGINT and SIGTERM. Once the first compiled call has finished (``graceful``), the first
    signal asks to stop after the current call (``requested``) and a second SIGINT stops at once;
    before that (building the state, compiling) any of them stops at once (``KeyboardInterrupt``),
    so that an interrupted start leaves nothing behind. Only in a single-process run: several
    processes must agree on when to stop, which they cannot here.

    Python runs signal handlers only between its own instructions, so while the main thread waits
    in a compiled call or a compilation that does not return, they would not run at all. A
    watcher thread sees every signal as it arrives (``signal.set_wakeup_fd``); when one that
    should stop at once (before the first call has finished, or a second signal) is not handled
    within ``HARD_STOP_S`` seconds, it prints one line and ends the process at once (status
    128 + signal). A run directory it leaves keeps a stale lock, which the next run takes over."""

    HARD_STOP_S = 5.0

    def __init__(self) -> None:
        self.requested: int | None = None
        self.graceful = False
        self.at_once = False  # a stop at once was raised (it may have been swallowed or wrapped)
        self.previous: dict[int, Any] = {}
        self.handled = 0  # signals the Python-level handler has run for
        self._wakeup: tuple[int, int] | None = None  # the pipe the C-level handler writes signals to
        self._previous_wakeup_fd = -1

    def __enter__(self) -> Interrupts:
        if jax.process_count() == 1:
            for signum in (signal.SIGINT, signal.SIGTERM):
                self.previous[signum] = signal.signal(signum, self._handle)
            if threading.current_thread() is threading.main_thread():
                read_fd, write_fd = os.pipe()
                os.set_blocking(write_fd, False)
                self._previous_wakeup_fd = signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
                self._wakeup = (read_fd, write_fd)
                threading.Thread(target=self._watch, args=(read_fd,), daemon=True, name="jaxpg-interrupts").start()
        self.previous_unraisablehook = sys.unraisablehook
        sys.unraisablehook = self._unraisable
        return self

    def _watch(self, read_fd: int) -> None:
        """The watcher thread: counts the SIGINT/SIGTERM that arrive and ends the process when
        one that should stop at once is left unhandled (the main thread is stuck outside Python)."""
        arrived = 0
        while True:
            try:
                data = os.read(read_fd, 64)
            except OSError:
                data = b""
            if not data:  # __exit__ closed the pipe's other end
                os.close(read_fd)
                return
            signums = [b for b in data if b in (signal.SIGINT, signal.SIGTERM)]
            if not signums:
                continue
            arrived += len(signums)
            if self.graceful and arrived < 2:
                continue  # the current call finishes, then a checkpoint is written: that may take long
            deadline = time.monotonic() + self.HARD_STOP_S
            while time.monotonic() < deadline and self.handled < arrived:
                time.sleep(0.05)
            if self.handled < arrived and self._wakeup is not None:
                name = signal.Signals(signums[-1]).name
                os.write(
                    2,
                    f"\n{name}: stopped at once: a compiled call or compilation did not return to Python within "
                    f"{self.HARD_STOP_S:g} s (continue from the latest checkpoint, if any, with --resume)\n".encode(),
                )
                os._exit(exit_status(signums[-1]))

    def _unraisable(self, report: Any) -> None:
        """Python's report of an exception it could not raise (one raised in a garbage-collection
        callback): silent for a stop at once, which the next callback raises again."""
        if not isinstance(report.exc_value, StopAtOnce):
            self.previous_unraisablehook(report)

    def _handle(self, signum: int, frame: Any) -> None:
        self.handled += 1
        at_once = not self.graceful or (self.requested is not None and signum == signal.SIGINT)
        self.requested = signum if self.requested is None else self.requested
        if at_once:
            self.requested = signum
            self.at_once = True
            raise StopAtOnce

    @contextlib.contextmanager
    def attributed(self) -> Any:
        """Any exception raised after a stop at once becomes ``StopAtOnce``.

        The handler raises wherever the main thread is, so its exception can come back wrapped (a
        C extension's import turns it into ``ImportError``); whatever follows the request is
        part of stopping."""
        try:
            yield
        except KeyboardInterrupt:
            raise
        except BaseException as exc:
            if self.at_once:
                raise StopAtOnce from exc
            raise

    def __exit__(self, *exc: Any) -> None:
        if self._wakeup is not None:
            signal.set_wakeup_fd(self._previous_wakeup_fd)
            _, write_fd = self._wakeup
            self._wakeup = None
            os.close(write_fd)  # the watcher reads the end of the pipe, closes its end and returns
        for signum, handler in self.previous.items():
            signal.signal(signum, handler)
        sys.unraisablehook = self.previous_unraisablehook


def exit_status(signum: int) -> int:
    return 128 + int(signum)
