"""Test-wide settings, applied before any test module imports MuJoCo."""

import os

# MuJoCo picks its OpenGL backend at first import: render offscreen through OSMesa on CPU machines
# (Debian's libosmesa6, installed by .ci/run), unless the caller chose another backend.
os.environ.setdefault("MUJOCO_GL", "osmesa")

# jaxpg's command lines keep compiled programs in a persistent cache (jaxpg.compile_cache): give the
# test session a fresh one, so tests never read programs compiled by an older checkout.
if "JAXPG_COMPILATION_CACHE" not in os.environ:
    import tempfile

    os.environ["JAXPG_COMPILATION_CACHE"] = tempfile.mkdtemp(prefix="jaxpg-xla-cache-")
