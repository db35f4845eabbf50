"""The one process-wide XLA setting jaxpg makes, when it is imported: XLA:CPU's memory-minimising
schedule in place of its concurrency-optimised one.

Why. MJX's Newton solver factors each env's constraint Hessian with LAPACK's Cholesky. jaxlib 0.10
splits a large batch of factorizations into chunks on XLA:CPU's intra-op thread pool, whose size is
the number of cores the process may use, and blocks its own pool thread until the chunks are done.
When XLA's concurrency-optimised schedule runs as many such calls side by side as the pool has
threads, every thread waits for chunks that no thread is free to run, and the program never
returns. On two cores (JAX 0.10.2) ``python experiments/hopper.py --num-envs 4096`` and an 8-seed
program of 512 envs each hung this way in their first block, the CPU idle; with this schedule both
ran to their end. A schedule orders operations; it does not change what they compute (the same
metrics, bit for bit, on Hopper), and Hopper's steps ran at the same speed on two cores.

How. Only with jaxlib 0.10: XLA aborts on a flag it does not know, and the flag could not be tried
on a later jaxlib here (whose LAPACK kernels reportedly no longer split the batch). XLA reads
``XLA_FLAGS`` once, when JAX starts its first backend, so the flag is added to the environment at
import, before that. Nothing is changed where ``XLA_FLAGS`` already names the option (set it to
``true`` there to keep XLA's default). Imported after JAX has started a backend, jaxpg's flag comes
too late for this process (its child processes still get it). The option, given per program as a
compile option instead, did not prevent the hang in NPG's update: only the process-wide flag did.
"""

from __future__ import annotations

import importlib.metadata
import os
from collections.abc import MutableMapping

OPTION = "xla_cpu_enable_concurrency_optimized_scheduler"
FLAG = f"--{OPTION}=false"
# The jaxlib releases known to split a LAPACK batch over XLA's pool and wait for it. Later releases
# are left alone: XLA aborts on a flag it does not know, and none could be tried here.
AFFECTED_JAXLIB = "0.10."


def with_option(xla_flags: str, option: str, value: str) -> str:
    """``xla_flags`` (an ``XLA_FLAGS`` value) with ``--option=value`` appended, unless it names
    ``option`` already (a user's own setting is kept)."""
    if option in xla_flags:
        return xla_flags
    return f"{xla_flags} --{option}={value}".strip()


def with_sequential_cpu_schedule(xla_flags: str) -> str:
    """``xla_flags`` with ``FLAG`` appended, unless it names ``OPTION``."""
    return with_option(xla_flags, OPTION, "false")


def set_sequential_cpu_schedule(
    environ: MutableMapping[str, str] = os.environ, jaxlib_version: str | None = None
) -> str:
    """Add ``FLAG`` to ``environ["XLA_FLAGS"]`` when the installed jaxlib (or ``jaxlib_version``)
    is a 0.10 release and ``XLA_FLAGS`` does not name ``OPTION``; returns its value ("" if unset).
    Processes started from this one inherit it."""
    version = jaxlib_version if jaxlib_version is not None else _installed_jaxlib()
    if version.startswith(AFFECTED_JAXLIB):
        environ["XLA_FLAGS"] = with_sequential_cpu_schedule(environ.get("XLA_FLAGS", ""))
    return environ.get("XLA_FLAGS", "")


def _installed_jaxlib() -> str:
    """The installed jaxlib's version ("" if none), read without importing it."""
    try:
        return importlib.metadata.version("jaxlib")
    except importlib.metadata.PackageNotFoundError:
        return ""
