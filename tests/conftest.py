"""Test-wide settings, applied before any test module imports MuJoCo."""

import os

# MuJoCo picks its OpenGL backend at first import: jaxpg.video.configure_gl sets MUJOCO_GL to a
# backend whose library loads (OSMesa from Debian's libosmesa6, which .ci/run installs, or EGL),
# and to none on a machine without either, so that `import mujoco` still works there and the
# rendering tests skip.
from jaxpg import video  # noqa: E402

video.configure_gl()

# jaxpg's command lines keep compiled programs in a persistent cache (jaxpg.compile_cache): give the
# test session a fresh one, so tests never read programs compiled by an older checkout.
if "JAXPG_COMPILATION_CACHE" not in os.environ:
    import tempfile

    os.environ["JAXPG_COMPILATION_CACHE"] = tempfile.mkdtemp(prefix="jaxpg-xla-cache-")
