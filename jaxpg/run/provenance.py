"""Where a run came from: the command line, package versions, the git commit and the devices."""

from __future__ import annotations

import datetime
import importlib.metadata
import platform
import shlex
import subprocess
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import jax

import jaxpg


def versions() -> dict[str, str]:
    """Versions of Python and the packages a run's numbers depend on."""
    out = {"python": platform.python_version(), "jaxpg": jaxpg.__version__}
    for dist in (
        "jax",
        "jaxlib",
        "mujoco",
        "mujoco-mjx",
        "flax",
        "optax",
        "orbax-checkpoint",
        "numpy",
        "warp-lang",
    ):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            pass
    commit = git_commit()
    if commit:
        out["jaxpg_git"] = commit
    return out


def git_commit() -> str | None:
    """The git commit of the jaxpg checkout (with ``+dirty`` when modified), if it is one."""
    root = Path(__file__).resolve().parent.parent
    if not (root / ".git").exists():
        return None

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], cwd=root, capture_output=True, text=True, timeout=5, check=True
        ).stdout.strip()

    try:
        with warnings.catch_warnings():
            # JAX warns about fork() in a threaded process; git is exec-ed at once: harmless.
            warnings.simplefilter("ignore", RuntimeWarning)
            commit = git("rev-parse", "HEAD")
            dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    return commit + ("+dirty" if dirty else "")


def device_info() -> dict[str, Any]:
    """The JAX backend, device kind and count the run used."""
    devices = jax.devices()
    return {
        "backend": jax.default_backend(),
        "kind": devices[0].device_kind,
        "count": len(devices),
        "host": platform.node(),
    }


def provenance(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """``info`` of a new run: command line, versions, device, time."""
    argv = list(sys.argv if argv is None else argv)
    return {
        "command": " ".join(_shell_quote(a) for a in argv),
        "versions": versions(),
        "device": device_info(),
        "created": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
    }


def _shell_quote(arg: str) -> str:
    return shlex.quote(arg)
