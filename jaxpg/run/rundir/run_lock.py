"""One writer per run directory: ``.jaxpg.lock`` (process id, host, start time)."""

from __future__ import annotations

import atexit
import datetime
import fcntl
import json
import os
import platform
import shlex
from pathlib import Path
from typing import Any

from jaxpg.run.rundir.layout import LOCK_FILE, RunDirError


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    return True


def lock_holder(run_dir: str | os.PathLike) -> dict[str, Any] | None:
    """The live process holding ``run_dir``'s lock (``{"pid", "host", "started"}``), or ``None``
    when the directory is free or its lock is stale (its process, on this host, has ended)."""
    path = Path(run_dir) / LOCK_FILE
    try:
        holder = json.loads(path.read_text())
        pid, host = int(holder["pid"]), str(holder["host"])
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, TypeError):
        return None  # a torn lock file: its writer died while writing it
    if host == platform.node() and (pid == os.getpid() or not pid_alive(pid)):
        return None
    return holder


def check_unlocked(run_dir: str | os.PathLike) -> None:
    """``RunDirError`` (one line) when another live process writes ``run_dir``."""
    holder = lock_holder(run_dir)
    if holder is not None:
        lock = Path(run_dir) / LOCK_FILE
        raise RunDirError(
            f"run directory {str(run_dir)!r} is in use by process {holder['pid']} on {holder['host']} "
            f"(since {holder.get('started', '?')}); wait for it to finish or stop it (if that process is gone, "
            f"delete {shlex.quote(str(lock))})"
        )


class RunLock:
    """The lock that makes one process the only writer of a run directory.

    ``acquire`` creates ``.jaxpg.lock`` (process id, host, start time) atomically; a lock whose
    process is gone (same host, PID no longer running) is stale and taken over. ``release``
    removes it; it also runs at interpreter exit, so any normal or error exit frees the directory
    (a ``kill -9`` leaves a stale lock, which the next writer detects by its PID).
    """

    def __init__(self, run_dir: str | os.PathLike):
        self.path = Path(run_dir) / LOCK_FILE
        self.held = False
        self.record = json.dumps(
            {
                "pid": os.getpid(),
                "host": platform.node(),
                "started": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
            }
        )

    def acquire(self) -> dict[str, Any] | None:
        """Take the lock (``RunDirError`` when a live process holds it); returns the record of the
        stale lock it took over (``{}`` for an unreadable one), ``None`` when there was none.

        Taking over a stale lock is three steps (see that its process has ended, delete it, create
        ours), so two writers that find the same stale lock could both pass the first before
        either creates its own, and the second would delete the first's new lock. Every writer
        therefore goes through them holding ``flock`` on the run directory itself (released when
        done; the lock file, not the ``flock``, is what marks the directory as taken)."""
        guard = os.open(self.path.parent, os.O_RDONLY)
        try:
            try:
                fcntl.flock(guard, fcntl.LOCK_EX)
            except OSError:  # a file system without flock (some network ones): the steps unguarded, as before
                pass
            return self._acquire_guarded()
        finally:
            os.close(guard)  # releases the flock

    def _acquire_guarded(self) -> dict[str, Any] | None:
        stale = None
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                check_unlocked(self.path.parent)
                try:
                    stale = json.loads(self.path.read_text())
                except (OSError, ValueError):
                    stale = {}
                stale = stale if isinstance(stale, dict) else {}
                self.path.unlink(missing_ok=True)  # stale: its process has ended
                continue
            with os.fdopen(fd, "w") as f:
                f.write(self.record)
            self.held = True
            atexit.register(self.release)
            return stale
        check_unlocked(self.path.parent)
        raise RunDirError(f"cannot lock run directory {str(self.path.parent)!r}")

    def copy_to(self, directory: str | os.PathLike) -> None:
        """Write this lock's record into ``directory`` as well (a directory about to take the
        locked one's place, so that it is never unlocked)."""
        with open(Path(directory) / LOCK_FILE, "x") as f:
            f.write(self.record)

    def release(self) -> None:
        if self.held:
            self.held = False
            try:
                holder = json.loads(self.path.read_text())
                if int(holder.get("pid", -1)) == os.getpid():
                    self.path.unlink()
            except (OSError, ValueError):
                pass
