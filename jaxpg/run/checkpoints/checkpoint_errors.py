"""Orbax's, TensorStore's and the OS's errors as one ``CheckpointError`` line saying what to do."""

from __future__ import annotations

import contextlib
import errno
import gc
import logging
import os
import re
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

MAX_REASON = 160  # characters of an Orbax/TensorStore error kept in a message


class CheckpointError(ValueError):
    """A checkpoint is missing, corrupt or does not fit the run; the message is one line."""


class Damaged(Exception):
    """A step that does not read back completely; the message says why (short, one line)."""


def clip_reason(text: str, limit: int = MAX_REASON) -> str:
    """``text`` on one line, at most ``limit`` characters (``...`` marks a cut)."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3].rstrip() + "..."


_TS_STATUS = re.compile(
    r"\b(NOT_FOUND|OUT_OF_RANGE|DATA_LOSS|INVALID_ARGUMENT|FAILED_PRECONDITION|PERMISSION_DENIED|"
    r"RESOURCE_EXHAUSTED|UNAVAILABLE|INTERNAL|UNKNOWN|ABORTED|ALREADY_EXISTS)\b"
)


_TS_FILE = re.compile(r'local file "([^"]+)"')


def first_line(e: BaseException, root: Path | None = None) -> str:
    """A short one-line description of ``e``: for TensorStore errors (kilobytes of driver specs)
    the status and the file it failed on (relative to ``root``), else the type and first line."""
    text = str(e)
    status, files = _TS_STATUS.search(text), _TS_FILE.findall(text)
    if status and files:
        path = files[-1]
        if root is not None and path.startswith(str(root) + os.sep):
            path = path[len(str(root)) + 1 :]
        return clip_reason(f"{status.group(1).lower().replace('_', ' ')}: {path}")
    lines = text.strip().splitlines()
    line = re.sub(r"\s*\[tensorstore_spec=.*", "", lines[0]) if lines else ""
    return clip_reason(f"{type(e).__name__}: {line}".rstrip(": "))


def exception_chain(e: BaseException) -> Iterator[BaseException]:
    """``e``, its causes and contexts, and the members of exception groups, each once."""
    seen: set[int] = set()
    todo = [e]
    while todo:
        x = todo.pop()
        if x is None or id(x) in seen:
            continue
        seen.add(id(x))
        yield x
        todo.extend([x.__cause__, x.__context__, *getattr(x, "exceptions", ())])


ERRNO_TEXT = {
    errno.ENOSPC: ("no space left on device",),
    errno.EDQUOT: ("disk quota exceeded",),
    errno.EACCES: ("permission denied",),
    errno.EPERM: ("operation not permitted",),
    errno.EROFS: ("read-only file system",),
}


def os_errno(e: BaseException) -> tuple[int, str | None] | None:
    """``(errno, filename)`` of the first disk-full/permission/read-only error in ``e``'s chain,
    also when a library (TensorStore) reports it as text; ``None`` for other errors."""
    for x in exception_chain(e):
        if isinstance(x, OSError) and x.errno in ERRNO_TEXT:
            return x.errno, x.filename
    for x in exception_chain(e):
        text = str(x).lower()
        for code, words in ERRNO_TEXT.items():
            if any(w in text for w in words):
                return code, None
    return None


def save_advice(code: int) -> str:
    """What happened and what to do, for a save that failed with ``code``."""
    if code in (errno.ENOSPC, errno.EDQUOT):
        what = "the disk is full" if code == errno.ENOSPC else "the disk quota is exceeded"
        return f"{what}; free some space (or keep fewer checkpoints: --keep-checkpoints), then continue with --resume"
    if code == errno.EROFS:
        return "the file system is read-only; write the run to a writable place (--run-dir)"
    return "permission denied; make the directory writable for this user, or choose another --run-dir"


def drop_closed_loop_noise(hook: Any) -> Any:
    """An ``unraisablehook`` that drops the ``RuntimeError: Event loop is closed`` TensorStore
    raises when reads still in flight after a failed Orbax restore complete on its closed loop;
    everything else goes to ``hook``."""

    def filtered(unraisable: Any) -> None:
        if isinstance(unraisable.exc_value, RuntimeError) and "Event loop is closed" in str(unraisable.exc_value):
            return
        hook(unraisable)

    filtered.drops_closed_loop_noise = True  # type: ignore[attr-defined]
    return filtered


@contextlib.contextmanager
def quiet_orbax() -> Iterator[None]:
    """Silence Orbax/absl log lines and asyncio task tracebacks during a read or write that may
    fail (the failure is reported as one ``CheckpointError`` line instead)."""
    if not getattr(sys.unraisablehook, "drops_closed_loop_noise", False):  # these arrive later, from other threads
        sys.unraisablehook = drop_closed_loop_noise(sys.unraisablehook)
    loggers = [logging.getLogger(name) for name in ("absl", "asyncio", "orbax")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    except BaseException:
        gc.collect()  # "Task exception was never retrieved" is logged when a failed task is freed
        raise
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)
