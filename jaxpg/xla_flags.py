"""The one process-wide setting jaxpg makes for XLA, when it is imported: with jaxlib 0.10 and
0.11.0, XLA:CPU's thread pool gets one thread (``NPROC=1``); ``with_option(s)``, which add
options to an ``XLA_FLAGS`` value; and ``accepted_options``, which of some options XLA knows.

Why. MJX factors each env's mass matrix and its Newton solver's Hessian with LAPACK's Cholesky.
jaxlib 0.10's LAPACK kernels split a large batch (one of more than about 2e5 flops, e.g. 2800 6x6
factorizations) into chunks, schedule the chunks on XLA:CPU's thread pool and block their own pool
thread until the chunks are done. When as many such calls run side by side as the pool has threads
(in training, a step's factorization and ``AutoReset``'s fresh reset state are independent), every
thread waits for chunks that no thread is free to run: the program never returns, the CPU idle.
``python experiments/hopper.py --num-envs 4096`` hung this way on two cores. A kernel splits its
batch only over more than one thread, so with a pool of one thread nothing waits on the pool.
``tests/test_xla_flags.py`` runs the reproduction: on two cores it hung under XLA's default flags
with jaxlib 0.10.2 and 0.11.0 and never with ``NPROC=1``; 0.11.1 and 0.11.2 returned without it,
so later releases are left alone (docs/benchmarks_archive.md has the counts).

Before, jaxpg set XLA's memory-minimising schedule instead
(``--xla_cpu_enable_concurrency_optimized_scheduler=false``). That made the hang rarer, not
impossible: the reproduction still hung with it on two idle cores, and in a CI run.

How. XLA's CPU client sizes its thread pool from the environment variable ``NPROC`` when it is set
(else from the cores the process may use), once, when JAX starts its CPU backend; so jaxpg sets it
at import, before that. A value you set yourself is kept. Imported after JAX has started its CPU
backend, jaxpg's setting comes too late for this process (processes it starts still inherit it).
XLA gives the pool at least as many threads as CPU devices
(``--xla_force_host_platform_device_count``), so with several CPU devices the hang is possible
again. Whether other XLA clients read ``NPROC`` (a GPU client's host threads) was not checked: the
GPU figures in BENCHMARKS.md ran on jaxlib 0.11.2, which this leaves alone.

Cost. None measured on two cores, where it was faster: ``python -m jaxpg.cli --env hopper
--num-envs 256 --iterations 24 --log-every 8`` trained faster with one thread than with two
(docs/benchmarks_archive.md), and so did the reproduction. Results may differ in their last bits from those of a pool of
several threads (a dot product's sum may be split between threads), so CPU metrics recorded before
this setting are not reproduced bit for bit; with the setting, the same seed gives the same numbers.
"""

from __future__ import annotations

import importlib.metadata
import os
import subprocess
import sys
from collections.abc import Iterable, MutableMapping

THREADS_VARIABLE = "NPROC"


def with_option(xla_flags: str, option: str, value: str) -> str:
    """``xla_flags`` (an ``XLA_FLAGS`` value) with ``--option=value`` appended, unless it names
    ``option`` already (a user's own setting is kept)."""
    if option in xla_flags:
        return xla_flags
    return f"{xla_flags} --{option}={value}".strip()


def with_options(xla_flags: str, options: Iterable[tuple[str, str]]) -> str:
    """``xla_flags`` with each ``(option, value)`` of ``options`` appended by ``with_option``."""
    for option, value in options:
        xla_flags = with_option(xla_flags, option, value)
    return xla_flags


def accepted_options(options: Iterable[tuple[str, str]], python: str = sys.executable) -> tuple[tuple[str, str], ...]:
    """The ``(option, value)`` pairs of ``options`` that this jaxlib's XLA accepts in ``XLA_FLAGS``.

    XLA ends a process whose ``XLA_FLAGS`` names a flag it does not know (XLA in jaxlib 0.11.2 no
    longer has ``xla_cpu_use_fusion_emitters``), so each option is tried in its own fresh
    interpreter (``python``), which compiles a tiny program on the CPU with it; the interpreters
    run side by side."""
    options = tuple(options)
    script = "import jax; jax.jit(lambda x: x + 1)(1.0)"
    environ = {**os.environ, "JAX_PLATFORMS": "cpu"}
    tries = [
        subprocess.Popen(
            [python, "-c", script],
            env={**environ, "XLA_FLAGS": f"--{option}={value}"},
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        for option, value in options
    ]
    return tuple(option for option, process in zip(options, tries, strict=True) if process.wait() == 0)


def splits_lapack_batches(jaxlib_version: str) -> bool:
    """Whether this jaxlib release's LAPACK kernels wait on XLA:CPU's pool for their chunks (found by
    running tests/test_xla_flags.py's program without the setting: the module docstring)."""
    return jaxlib_version.startswith("0.10.") or jaxlib_version == "0.11.0"


def set_single_thread_cpu_pool(
    environ: MutableMapping[str, str] = os.environ, jaxlib_version: str | None = None
) -> str:
    """Set ``environ["NPROC"] = "1"`` when the installed jaxlib (or ``jaxlib_version``) splits LAPACK
    batches and ``NPROC`` is unset; returns its value ("" if unset). Processes started from this one
    inherit it."""
    version = jaxlib_version if jaxlib_version is not None else installed_jaxlib()
    if splits_lapack_batches(version):
        environ.setdefault(THREADS_VARIABLE, "1")
    return environ.get(THREADS_VARIABLE, "")


def installed_jaxlib() -> str:
    """The installed jaxlib's version ("" if none), read without importing it."""
    try:
        return importlib.metadata.version("jaxlib")
    except importlib.metadata.PackageNotFoundError:
        return ""
