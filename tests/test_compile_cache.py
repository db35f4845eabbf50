"""The persistent compilation cache: where it lives, how it is turned off, and that a second
process loads a program the first one compiled."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from jaxpg.run.host import compile_cache


def test_cache_dir_from_environment(tmp_path):
    assert compile_cache.cache_dir({"JAXPG_COMPILATION_CACHE": str(tmp_path)}) == tmp_path
    assert compile_cache.cache_dir({"JAXPG_COMPILATION_CACHE": "off"}) is None
    assert compile_cache.cache_dir({"JAX_COMPILATION_CACHE_DIR": str(tmp_path)}) == tmp_path
    assert compile_cache.cache_dir({}) == compile_cache.DEFAULT_DIR.expanduser()


SCRIPT = textwrap.dedent(
    """
    import collections, json, sys
    import jax, jax.numpy as jnp
    from jaxpg.run.host import compile_cache
    events = collections.Counter()
    jax.monitoring.register_event_listener(lambda event, **kwargs: events.update([event]))
    compile_cache.enable(sys.argv[1], min_compile_seconds=0.0)
    f = jax.jit(lambda x: jnp.sin(x) @ jnp.cos(x).T + 1.0)
    value = float(f(jnp.ones((8, 8))).sum())
    prefix = "/jax/compilation_cache/"
    cache_events = {k[len(prefix):]: n for k, n in events.items() if k.startswith(prefix)}
    print(json.dumps({"value": value, "events": cache_events}))
    """
)


def test_second_process_reads_the_cache(tmp_path):
    """The first process compiles and writes its programs to the cache; the second one loads every
    program from it and compiles none. JAX reports both through ``jax.monitoring`` events: a write
    records ``/jax/compilation_cache/cache_misses``, a load ``/jax/compilation_cache/cache_hits``."""
    import jax

    if not hasattr(jax.monitoring, "register_event_listener"):
        pytest.skip(f"jax {jax.__version__} has no jax.monitoring.register_event_listener")
    runs = []
    for _ in range(2):
        argv = [sys.executable, "-c", SCRIPT, str(tmp_path)]
        proc = subprocess.run(argv, capture_output=True, text=True, timeout=900)
        assert proc.returncode == 0, proc.stderr[-2000:]
        runs.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    first, second = runs
    assert first["value"] == second["value"]
    assert any(p.is_file() for p in Path(tmp_path).rglob("*")), "the first process wrote nothing to the cache"
    if not first["events"]:  # the cache was written, so it was on: this JAX does not report it
        pytest.skip(f"jax {jax.__version__} records no /jax/compilation_cache/ monitoring events")
    assert first["events"].get("cache_misses", 0) >= 1 and first["events"].get("cache_hits", 0) == 0, first
    # Every program of the second process came from the cache: hits, no writes.
    hits, requests = second["events"].get("cache_hits", 0), second["events"].get("compile_requests_use_cache", 0)
    assert hits >= 1 and hits == requests and second["events"].get("cache_misses", 0) == 0, second
