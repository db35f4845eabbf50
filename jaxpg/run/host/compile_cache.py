"""JAX's persistent compilation cache, turned on for jaxpg's command lines and benchmarks.

A training program (MJX physics, rollout, GAE, conjugate gradient, value fit) takes many seconds to
compile; with the cache a second run of the same program on the same machine loads the compiled
executable from disk instead. The cache is keyed by JAX on the lowered program, the JAX and XLA
versions and the device, so a changed config or shape simply compiles again. Programs with
MuJoCo Warp's FFI calls are safe to cache: the names of Warp's FFI targets and call ids are part
of the lowered program, hence of the key, and are registered again whenever the program is traced.

Where: ``$JAXPG_COMPILATION_CACHE`` if set (``off`` turns the cache off), else JAX's own
``JAX_COMPILATION_CACHE_DIR`` if set, else ``~/.cache/jaxpg/xla``.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import jax

ENV_VAR = "JAXPG_COMPILATION_CACHE"
DEFAULT_DIR = Path("~/.cache/jaxpg/xla")
_OFF = ("off", "0", "none", "false", "")


def cache_dir(environ: dict[str, str] | None = None) -> Path | None:
    """The cache directory the environment asks for, or ``None`` when the cache is off."""
    environ = dict(os.environ) if environ is None else environ
    if ENV_VAR in environ:
        value = environ[ENV_VAR].strip()
        return None if value.lower() in _OFF else Path(value).expanduser()
    if environ.get("JAX_COMPILATION_CACHE_DIR"):
        return Path(environ["JAX_COMPILATION_CACHE_DIR"]).expanduser()
    return DEFAULT_DIR.expanduser()


def enable(directory: str | os.PathLike | None = None, min_compile_seconds: float = 1.0) -> Path | None:
    """Turn on JAX's persistent compilation cache; returns its directory (``None``: left off).

    Args:
      directory: where to keep compiled programs (default: ``cache_dir()``).
      min_compile_seconds: only programs that took at least this long to compile are stored.
    Call it before the first compilation. A directory that cannot be created or written (tried by
    creating and removing a temporary file in it) leaves the cache off, with one ``warning:``
    line on stderr saying so.
    """
    path = Path(directory).expanduser() if directory is not None else cache_dir()
    if path is None:
        return None
    problem = _unusable(path)
    if problem is not None:
        print(
            f"warning: compilation cache {path} is not usable ({problem}); compiling without it "
            f"(set {ENV_VAR} to a writable directory, or off)",
            file=sys.stderr,
        )
        return None
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", min_compile_seconds)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    return path


def enable_unless_chosen() -> Path | None:
    """``enable()`` in a process that has not chosen a cache directory itself (JAX's
    ``jax_compilation_cache_dir`` unset), e.g. one that makes jaxpg's Gymnasium envs; returns the
    directory in use (``None``: off). Safe after the process compiled other programs: JAX, which
    settles its cache at the first compilation, settles it again at the next one. Processes share
    the directory: JAX writes an entry once, under a name of its key, and a process that reads an
    entry another is still writing only warns and compiles the program itself."""
    chosen = jax.config.jax_compilation_cache_dir
    if chosen:
        return Path(chosen)
    path = enable()
    if path is not None:
        from jax.experimental.compilation_cache import compilation_cache as jax_cache

        jax_cache.reset_cache()
    return path


def _unusable(path: Path) -> str | None:
    """Why ``path`` cannot hold the cache (its creation or a test file in it fails), or ``None``."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=path, prefix=".jaxpg-write-test-")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        return e.strerror or str(e)
    return None
