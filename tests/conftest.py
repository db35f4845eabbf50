"""Test-wide settings, applied before any test module imports MuJoCo."""

import os

import pytest

# MuJoCo picks its OpenGL backend at first import: jaxpg.video.configure_gl sets MUJOCO_GL to a
# backend whose library loads (OSMesa from Debian's libosmesa6, which .ci/run installs, or EGL),
# and to none on a machine without either, so that `import mujoco` still works there and the
# rendering tests skip.
from jaxpg import video  # noqa: E402

video.configure_gl()

# jaxpg's command lines keep compiled programs in a persistent cache (jaxpg.run.compile_cache): give the
# test session a fresh one, so tests never read programs compiled by an older checkout.
if "JAXPG_COMPILATION_CACHE" not in os.environ:
    import tempfile

    os.environ["JAXPG_COMPILATION_CACHE"] = tempfile.mkdtemp(prefix="jaxpg-xla-cache-")


_CACHE_DIR_AT_START: list = []  # JAX's jax_compilation_cache_dir when the first test starts


@pytest.fixture(autouse=True)
def _persistent_compilation_cache_left_as_found():
    """``jaxpg.run.main.main`` turns JAX's persistent compilation cache on for the rest of its process
    (so that a second run loads its programs). Tests that run the command line in this process
    (module fixtures too) would leave it on for every later test, which then writes each program it
    compiles to disk: after each test the cache is set back to how the session found it, so that
    every test compiles as it would alone."""
    import jax
    from jax.experimental.compilation_cache import compilation_cache

    if not _CACHE_DIR_AT_START:
        _CACHE_DIR_AT_START.append(jax.config.jax_compilation_cache_dir)
    yield
    if jax.config.jax_compilation_cache_dir != _CACHE_DIR_AT_START[0]:
        jax.config.update("jax_compilation_cache_dir", _CACHE_DIR_AT_START[0])
        compilation_cache.reset_cache()


@pytest.fixture(autouse=True, scope="module")
def _compiled_programs_freed_after_each_module():
    """Free every compiled program after each test module: a single pytest process compiles
    hundreds of MJX programs, and late in the suite XLA's CPU compiler aborted (twice, at
    ``tests/test_train.py``) in a process that still held all of them."""
    yield
    import gc

    import jax

    jax.clear_caches()
    gc.collect()
