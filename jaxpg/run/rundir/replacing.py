"""Replacing a run directory safely (``--overwrite``): the old run is moved aside, put back if the
new one ends before its first checkpoint, and recovered after a crash; resuming one."""

from __future__ import annotations

import datetime
import os
import shlex
import shutil
import sys
from pathlib import Path
from typing import Any

from jaxpg.run.checkpoints import checkpoint_errors, checkpointer
from jaxpg.run.command.plan import Plan
from jaxpg.run.host import provenance
from jaxpg.run.outputs import metrics_log
from jaxpg.run.rundir import directory, layout, run_lock

REPLACED = ".replaced-"  # RUN.replaced-PID: the run that process PID's --overwrite moved aside


NEW = ".new-"  # RUN.new-PID: the empty, locked directory that takes RUN's place


def resume_command(run_dir: str | os.PathLike) -> str:
    """The command that continues ``run_dir``, quoted for a POSIX shell."""
    return f"python -m jaxpg.cli --resume {shlex.quote(str(run_dir))}"


def has_checkpoint(run_dir: str | os.PathLike) -> bool:
    """Whether ``run_dir`` holds a committed checkpoint (a step ``--resume`` could start from);
    ``True`` as well when its checkpoint directory cannot be read, so that nothing is taken for
    empty that is not known to be."""
    ckpt_dir = Path(run_dir) / layout.CHECKPOINT_DIR
    if not ckpt_dir.is_dir():
        return False
    try:
        checkpoints = checkpointer.Checkpointer(ckpt_dir, keep=None)
        try:
            return bool(checkpoints.steps())
        finally:
            checkpoints.close()
    except (OSError, checkpoint_errors.CheckpointError):
        return True


def is_replaceable(run_dir: str | os.PathLike) -> bool:
    """``directory.check_replaceable`` as a yes or no."""
    try:
        directory.check_replaceable(run_dir)
    except (OSError, layout.RunDirError):
        return False
    return True


def exists_message(run_dir: Path) -> str:
    """Why a new run cannot go into the existing, non-empty ``run_dir``, and what to do instead."""
    if not is_replaceable(run_dir):
        return f"run directory {str(run_dir)!r} exists and is not a jaxpg run; choose another --run-dir"
    if not has_checkpoint(run_dir):
        return (
            f"run directory {str(run_dir)!r} holds a run that has no checkpoint (it stopped before its first one, "
            "so there is nothing to resume); pass --overwrite to start it again"
        )
    return (
        f"run directory {str(run_dir)!r} exists; pass --overwrite to replace it or --resume "
        f"{shlex.quote(str(run_dir))} to continue it"
    )


def prepare_run_dir(plan_: Plan, lock: run_lock.RunLock) -> float:
    """Lock the run directory, then create (or replace, or reopen) it; returns the wall-time offset.

    ``lock`` is taken before anything is written, so that a second writer is refused without
    having changed a byte. A new run then checks the directory again (another process may have
    written it since the command was planned): it must be empty, or with ``--overwrite`` a jaxpg
    run (``directory.check_replaceable``). ``--overwrite`` moves the old run aside, beside the
    directory a symbolic link points to (the link stays a link), to ``RUN.replaced-PID``, and an
    empty locked directory takes its place; the old run is deleted once the new run has written a
    checkpoint, and put back if the new run stops before (``finish_run_dir``), so that nothing
    on disk is lost to a run that never got going.
    """
    run_dir, run = plan_.run_dir, plan_.run
    if plan_.start > 0:
        _note_stale_lock(lock.acquire(), run_dir)
        _drop_later_checkpoints(run_dir, plan_.start, plan_.later_checkpoints)
        wall_offset = metrics_log.truncate_metrics(run_dir, plan_.start)
        history = run.info.setdefault("resumes", [])
        history.append(
            {
                "from_iteration": plan_.start,
                "command": shlex.join(plan_.command),
                "time": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
            }
        )
        run.save(run_dir)
        return wall_offset
    real = run_dir.resolve()
    created = not real.exists()
    real.mkdir(parents=True, exist_ok=True)
    _note_stale_lock(lock.acquire(), run_dir)
    if any(entry.name != layout.LOCK_FILE for entry in real.iterdir()):
        if not plan_.overwrite:
            raise layout.RunDirError(exists_message(run_dir) + " (it was written after this command started)")
        directory.check_replaceable(real, shown=run_dir)
        plan_.replaced = _move_aside(real, lock)
    plan_.created, plan_.fresh = created, True
    run.info = provenance.provenance([sys.argv[0], *plan_.command])
    run.save(real)
    return 0.0


def _drop_later_checkpoints(run_dir: Path, start: int, later: list[int]) -> None:
    """``--from-step``: delete the checkpoints after ``start`` (``later``), which belong to the
    continuation the resume replaces (the new one writes its own at those iterations), saying so
    in one ``note:`` line."""
    if not later:
        return
    ckpt_dir = run_dir / layout.CHECKPOINT_DIR
    for step in later:
        for path in [ckpt_dir / str(step), *ckpt_dir.glob(f"{step}.orbax-checkpoint-tmp*")]:
            shutil.rmtree(path)
    print(
        f"note: --from-step {start}: deleted the later checkpoint{'s' if len(later) > 1 else ''} "
        f"{', '.join(map(str, later))} and the metrics after iteration {start}",
        file=sys.stderr,
    )


def _note_stale_lock(stale: dict[str, Any] | None, run_dir: Path) -> None:
    if stale is not None:
        who = f"process {stale['pid']}" if "pid" in stale else "a process"
        print(
            f"note: took over {str(run_dir / layout.LOCK_FILE)!r}, left by {who} that has ended",
            file=sys.stderr,
        )


def _move_aside(real: Path, lock: run_lock.RunLock) -> Path:
    """Put an empty directory, already locked by ``lock``, in the place of the run in ``real``;
    returns where the old run went (``real.replaced-PID``, this process's lock file removed)."""
    fresh = real.with_name(f"{real.name}{NEW}{os.getpid()}")
    replaced = real.with_name(f"{real.name}{REPLACED}{os.getpid()}")
    fresh.mkdir()
    try:
        lock.copy_to(fresh)
        real.rename(replaced)
    except OSError:
        shutil.rmtree(fresh, ignore_errors=True)
        raise
    try:
        fresh.rename(real)
    except OSError:
        replaced.rename(real)
        shutil.rmtree(fresh, ignore_errors=True)
        raise
    (replaced / layout.LOCK_FILE).unlink(missing_ok=True)
    return replaced


def _put_back(replaced: Path, real: Path) -> None:
    """Move the run in ``replaced`` back to ``real``, deleting what is there (a run without a checkpoint)."""
    if not real.exists() and not real.is_symlink():
        replaced.rename(real)
        return
    abandoned = real.with_name(f"{real.name}.abandoned-{os.getpid()}")
    real.rename(abandoned)
    replaced.rename(real)
    shutil.rmtree(abandoned, ignore_errors=True)


def finish_run_dir(plan_: Plan, checkpointed: bool) -> str:
    """After the run: drop the run it replaced once the new one has a checkpoint; otherwise (it
    stopped before its first checkpoint) put back what was there (the old run, or nothing), so
    that the same command can simply be run again. A run directory that holds a committed
    checkpoint (``has_checkpoint``) counts as ``checkpointed`` whatever the caller says: no
    interrupt or failure ever removes a run that has one. Returns a note for the user ('' if
    none), which says where things are."""
    run_dir = plan_.run_dir
    if plan_.start > 0 or not plan_.fresh:
        return ""
    # What is on disk decides, not what the caller believes: a second interrupt can arrive after
    # a checkpoint was written and before anyone noted it. A run with a checkpoint is never removed.
    checkpointed = checkpointed or has_checkpoint(run_dir)
    if checkpointed:
        if plan_.replaced is not None:
            shutil.rmtree(plan_.replaced, ignore_errors=True)
        return ""
    real = run_dir.resolve()
    if plan_.replaced is not None:
        _put_back(plan_.replaced, real)
        return f"; the run it was replacing is back in {run_dir}"
    if plan_.created:
        shutil.rmtree(real, ignore_errors=True)
        return f"; {run_dir} was removed (no checkpoint had been written)"
    for entry in real.iterdir():  # it was empty before this run
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
    return f"; {run_dir} is empty again (no checkpoint had been written)"


def stopped_at_once_note(plan_: Plan, checkpointed: bool) -> str:
    """What a run stopped at once (a second Ctrl-C, or one before the first call returned) tells
    the user, after putting its directory in order (``finish_run_dir``, which never removes a run
    that has a checkpoint): where the old run went, or how to continue from the latest checkpoint."""
    note = finish_run_dir(plan_, checkpointed)
    if not note and has_checkpoint(plan_.run_dir):
        return f"; continue from its latest checkpoint with: {resume_command(plan_.run_dir)}"
    return note


def _dead_siblings(real: Path, mark: str) -> list[tuple[Path, int]]:
    """The siblings ``<name><mark><pid>`` of ``real`` whose process (on this host) has ended."""
    prefix = real.name + mark
    found = []
    for path in real.parent.iterdir():
        pid = path.name[len(prefix) :]
        if path.name.startswith(prefix) and pid.isdigit() and int(pid) != os.getpid():
            if not run_lock.pid_alive(int(pid)):
                found.append((path, int(pid)))
    return sorted(found, key=lambda item: item[1])


def recover_replaced(run_dir: str | os.PathLike) -> list[str]:
    """Finish what an ``--overwrite`` of ``run_dir`` left undone when its process was killed
    before it could (``kill -9``, a power cut): returns the lines that tell the user.

    A ``RUN.replaced-PID`` beside the run directory (beside the directory a symbolic link points
    to) whose process has ended is the run that ``--overwrite`` moved aside. When ``RUN`` holds
    no checkpoint (the new run never got going; it is removed) or is gone, the old run is put
    back; otherwise both stay and the note says where the old one is. A live writer of ``RUN``
    is left alone (the command is refused by its lock anyway).
    """
    run_dir = Path(run_dir)
    real = run_dir.resolve()
    if not real.parent.is_dir():
        return []
    for fresh, _ in _dead_siblings(real, NEW):  # never took RUN's place: holds the dead lock at most
        if set(os.listdir(fresh)) <= {layout.LOCK_FILE}:
            shutil.rmtree(fresh, ignore_errors=True)
    aside = _dead_siblings(real, REPLACED)
    if not aside or (real.exists() and run_lock.lock_holder(real) is not None):
        return []
    shown = " and ".join(shlex.quote(str(path)) for path, _ in aside)
    pids = ", ".join(str(pid) for _, pid in aside)
    if real.is_dir() and has_checkpoint(real):
        return [
            f"note: {shown} holds the run that an --overwrite of {run_dir} moved aside (process {pids} ended "
            f"before deleting it); {run_dir} holds the new run: delete {shown} once you no longer need it"
        ]
    if len(aside) > 1 or (real.exists() and not is_replaceable(real)):
        return [
            f"note: {run_dir} holds no checkpoint, and {shown} hold what an --overwrite moved aside (process "
            f"{pids} ended first): move back by hand the one you want"
        ]
    path, pid = aside[0]
    lock = run_lock.RunLock(real)
    if real.exists():
        lock.acquire()  # takes over the dead process's lock; goes with the directory it locks
    try:
        (path / layout.LOCK_FILE).unlink(missing_ok=True)  # the dead process's lock on the old run
        _put_back(path, real)
    finally:
        lock.release()
    return [
        f"note: an --overwrite of {run_dir} (process {pid}) ended before its first checkpoint; the run it was "
        f"replacing is back in {run_dir} (from {path})"
    ]
