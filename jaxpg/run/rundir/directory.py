"""What a run directory holds: a jaxpg run (``check_replaceable``) or something else.

``--overwrite`` deletes only what jaxpg wrote, checked entry by entry down the whole tree:
``sinks.run_entries()`` at the top (the run's own files and what its registered sinks declare),
``sinks.run_subentries()`` inside the sinks' directories (``tensorboard/``, ``videos/``), and
inside ``checkpoints/`` only Orbax's step directories (and its temporary ones), each holding
nothing but the files its own checksum manifest lists (a step written before manifests existed:
nothing but Orbax's items at its top). A symbolic link inside a run is never
jaxpg's. The working directory and the directories above it are never replaced.
"""

from __future__ import annotations

import json
import os
import re
import types
from pathlib import Path

from jaxpg.run.rundir.config_io import RunConfig
from jaxpg.run.rundir.layout import CHECKPOINT_DIR, CONFIG_FILE, RunDirError

MANIFEST = "jaxpg_sha256.json"  # jaxpg.run.checkpoints.checkpoint_format.MANIFEST (that module loads JAX)


def _sinks() -> types.ModuleType:
    """``jaxpg.run.outputs.sinks``, imported when a directory is checked: it imports the sinks (and JAX)."""
    from jaxpg.run.outputs import sinks

    return sinks


STEP_TOP = frozenset({"state", "policy", "meta", "_CHECKPOINT_METADATA", "commit_success.txt"})
"""What Orbax writes at the top of a checkpoint step (its three items, metadata, commit marker)."""


def _step_foreign(step_dir: Path, shown: str) -> list[str]:
    """The entries of the checkpoint step ``step_dir`` that its save did not write: every file must
    be listed in its checksum manifest (steps without one: only Orbax's items at its top)."""
    extra = {MANIFEST, MANIFEST + ".tmp"}
    try:
        listed = json.loads((step_dir / MANIFEST).read_text())["files"]
        known = set(listed) if isinstance(listed, dict) else None
    except (OSError, ValueError, KeyError, TypeError):
        known = None
    if known is None:  # an older step, or a save killed before its manifest
        return [f"{shown}/{name}" for name in sorted(os.listdir(step_dir)) if name not in STEP_TOP | extra]
    found = []
    for root, dirs, files in os.walk(step_dir):
        rel_root = Path(root).relative_to(step_dir)
        for name in sorted(dirs):
            if (Path(root) / name).is_symlink():
                found.append(f"{shown}/{(rel_root / name).as_posix()}")
        dirs[:] = [d for d in dirs if not (Path(root) / d).is_symlink()]
        for name in sorted(files):
            rel = (rel_root / name).as_posix()
            if (Path(root) / name).is_symlink() or (rel not in known and rel not in extra):
                found.append(f"{shown}/{rel}")
    return found


def _checkpoints_foreign(ckpt_dir: Path) -> list[str]:
    """The entries of ``checkpoints/`` that Orbax did not write for a run (step directories
    ``<step>`` and temporary ``<step>.orbax-checkpoint-tmp*``)."""
    found = []
    for entry in sorted(os.scandir(ckpt_dir), key=lambda e: e.name):
        shown = f"{CHECKPOINT_DIR}/{entry.name}"
        step, _, tail = entry.name.partition(".")
        if entry.is_symlink() or not entry.is_dir() or not step.isdigit():
            found.append(shown)
        elif tail:
            if not tail.startswith("orbax-checkpoint-tmp"):
                found.append(shown)
        else:
            found.extend(_step_foreign(Path(entry.path), shown))
    return found


def _tree_foreign(top: Path, name: str) -> list[str]:
    """The entries under the run's directory ``name`` (``tensorboard``, ``videos``) that match
    none of ``sinks.run_subentries()[name]``; a foreign directory is named once, not its contents."""
    patterns = _sinks().run_subentries()[name]
    found = []
    for root, dirs, files in os.walk(top / name):
        rel_root = Path(root).relative_to(top)
        for entry in sorted(dirs + files):
            rel = (rel_root / entry).as_posix()
            path = Path(root) / entry
            if path.is_symlink() or not any(re.fullmatch(p, rel) for p in patterns):
                found.append(rel)
                if entry in dirs:
                    dirs.remove(entry)
    return found


def foreign_entries(run_dir: str | os.PathLike) -> list[str]:
    """The paths (relative to ``run_dir``, sorted) that a jaxpg run does not write, checked down
    the whole tree (module docstring)."""
    top = Path(run_dir)
    registry = _sinks()
    known, dirs, inside = registry.run_entries(), registry.run_dirs(), registry.run_subentries()
    found = []
    for entry in sorted(os.scandir(top), key=lambda e: e.name):
        name = entry.name
        if name not in known:
            found.append(name)
        elif entry.is_symlink():
            found.append(name)
        elif entry.is_dir() != (name in dirs):
            found.append(name)  # a file where a run writes a directory, or the other way round
        elif name == CHECKPOINT_DIR:
            found.extend(_checkpoints_foreign(top / name))
        elif name in inside:
            found.extend(_tree_foreign(top, name))
    return sorted(found)


def check_entry_types(run_dir: str | os.PathLike) -> None:
    """``RunDirError`` (one line) when an entry of ``run_dir`` that a run writes is of the wrong
    type: a directory where a run writes a file (``metrics.jsonl``, ``.jaxpg.lock``) or the other
    way round (``checkpoints``), which jaxpg will not read, write or delete."""
    registry = _sinks()
    dirs = registry.run_dirs()
    for name in sorted(registry.run_entries()):
        path = Path(run_dir) / name
        if not (path.exists() or path.is_symlink()):
            continue
        is_dir = path.is_dir()
        if is_dir != (name in dirs):
            what, wanted = ("a directory", "a file") if is_dir else ("not a directory", "a directory")
            raise RunDirError(
                f"{str(path)!r} is {what}, where a run writes {wanted}; move it out of the run directory "
                "(jaxpg neither reads nor deletes it)"
            )


def check_not_working_directory(run_dir: str | os.PathLike, name: str, what: str = "--overwrite") -> None:
    """``RunDirError`` (one line) when ``run_dir`` is the working directory or a directory above
    it: replacing it would pull the ground from under the command (and the user's shell)."""
    real = Path(run_dir).resolve()
    try:
        cwd = Path.cwd().resolve()
    except OSError:  # the working directory itself was deleted
        return
    if real == cwd or real in cwd.parents:
        where = "the working directory" if real == cwd else "a directory above the working directory"
        raise RunDirError(
            f"refusing to {what} {name!r}: it is {where}; run the command from outside it (cd ..) and name "
            "the run directory from there"
        )


def check_replaceable(run_dir: str | os.PathLike, shown: str | os.PathLike | None = None) -> None:
    """``RunDirError`` (one line) unless ``run_dir`` is a jaxpg run that ``--overwrite`` may
    replace: not the working directory or above it, its ``config.json`` reads as a ``RunConfig``
    and it holds nothing else than what a run writes (``foreign_entries``, down the whole tree).
    ``shown``: the name to print (default ``run_dir``)."""
    name = str(run_dir if shown is None else shown)
    check_not_working_directory(run_dir, name)
    if not (Path(run_dir) / CONFIG_FILE).is_file():
        raise RunDirError(f"refusing to --overwrite {name!r}: it is not a jaxpg run directory (no {CONFIG_FILE})")
    try:
        RunConfig.load(run_dir)
    except RunDirError as e:
        first = str(e).splitlines()[0]
        raise RunDirError(f"refusing to --overwrite {name!r}: it is not a jaxpg run directory ({first})") from None
    foreign = foreign_entries(run_dir)
    if foreign:
        listed = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
        raise RunDirError(
            f"refusing to --overwrite {name!r}: besides a jaxpg run it holds {listed}, which a run does not write; "
            "move them out or choose another --run-dir"
        )


def enclosing_run(path: str | os.PathLike) -> Path | None:
    """The nearest directory above ``path`` that holds a jaxpg run (its ``config.json`` reads as
    a ``RunConfig``), or ``None``: a new run must not be written inside another run."""
    for parent in Path(path).absolute().parents:
        try:
            if (parent / CONFIG_FILE).is_file():
                RunConfig.load(parent)
                return parent
        except (OSError, RunDirError):
            continue
    return None
