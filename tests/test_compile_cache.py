"""The persistent compilation cache: where it lives, how it is turned off, and that a second
process loads a program the first one compiled."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

from jaxpg import compile_cache


def test_cache_dir_from_environment(tmp_path):
    assert compile_cache.cache_dir({"JAXPG_COMPILATION_CACHE": str(tmp_path)}) == tmp_path
    assert compile_cache.cache_dir({"JAXPG_COMPILATION_CACHE": "off"}) is None
    assert compile_cache.cache_dir({"JAX_COMPILATION_CACHE_DIR": str(tmp_path)}) == tmp_path
    assert compile_cache.cache_dir({}) == compile_cache.DEFAULT_DIR.expanduser()


SCRIPT = textwrap.dedent(
    """
    import sys, jax, jax.numpy as jnp
    from jaxpg import compile_cache
    compile_cache.enable(sys.argv[1], min_compile_seconds=0.0)
    f = jax.jit(lambda x: jnp.sin(x) @ jnp.cos(x).T + 1.0)
    print(float(f(jnp.ones((8, 8))).sum()))
    """
)


def test_second_process_reads_the_cache(tmp_path):
    runs = [
        subprocess.run([sys.executable, "-c", SCRIPT, str(tmp_path)], capture_output=True, text=True, timeout=300)
        for _ in range(2)
    ]
    for run in runs:
        assert run.returncode == 0, run.stderr[-2000:]
    assert runs[0].stdout == runs[1].stdout
    entries = [p for p in Path(tmp_path).rglob("*") if p.is_file()]
    assert entries, "the first process wrote nothing to the cache"
    mtimes = {p: p.stat().st_mtime for p in entries}
    # The second process found the program and did not write it again.
    assert all(p.stat().st_mtime == mtimes[p] for p in entries)
