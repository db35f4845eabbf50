"""Test-wide settings, applied before any test module imports MuJoCo."""

import os

# MuJoCo picks its OpenGL backend at first import: render offscreen through OSMesa on CPU machines
# (Debian's libosmesa6, installed by .ci/run), unless the caller chose another backend.
os.environ.setdefault("MUJOCO_GL", "osmesa")
