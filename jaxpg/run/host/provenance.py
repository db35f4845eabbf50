"""Where a run came from: the command line, package versions, the git commit, the devices and the
environment variables that change how JAX, XLA and MuJoCo run."""

from __future__ import annotations

import datetime
import importlib.metadata
import os
import platform
import shlex
import subprocess
import sys
import warnings
from collections.abc import Mapping, Sequence
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


# Environment variables that change a run's numbers or how it runs: XLA's options and memory, JAX's
# platforms and precision, jaxpg's CPU pool (``jaxpg.xla_flags``) and MJX import, MuJoCo's renderer,
# the GPUs visible.
SETTINGS_VARIABLES = (
    "XLA_FLAGS",
    "NPROC",
    "XLA_PYTHON_CLIENT_PREALLOCATE",
    "XLA_PYTHON_CLIENT_MEM_FRACTION",
    "XLA_CLIENT_MEM_FRACTION",
    "XLA_PYTHON_CLIENT_ALLOCATOR",
    "JAX_PLATFORMS",
    "JAX_ENABLE_X64",
    "JAX_DEFAULT_MATMUL_PRECISION",
    "JAXPG_MJX_WARP",
    "MUJOCO_GL",
    "CUDA_VISIBLE_DEVICES",
)


def environment_settings(environ: Mapping[str, str] = os.environ) -> dict[str, str]:
    """The ``SETTINGS_VARIABLES`` set in ``environ``, by name (those jaxpg set itself included)."""
    return {name: environ[name] for name in SETTINGS_VARIABLES if name in environ}


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
    """``info`` of a new run: command line, versions, device, environment settings, time."""
    argv = list(sys.argv if argv is None else argv)
    return {
        "command": " ".join(_shell_quote(a) for a in argv),
        "versions": versions(),
        "device": device_info(),
        "environment": environment_settings(),
        "created": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
    }


def _shell_quote(arg: str) -> str:
    return shlex.quote(arg)
