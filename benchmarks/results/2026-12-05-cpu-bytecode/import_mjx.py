"""Seconds to import JAX, then ``mujoco.mjx`` (with MuJoCo Warp's modules), in this process."""

import time

t0 = time.perf_counter()
import jax  # noqa: E402, F401

t1 = time.perf_counter()
from mujoco import mjx  # noqa: E402

t2 = time.perf_counter()
print(f"jax {t1 - t0:.2f} s, mujoco.mjx {t2 - t1:.2f} s, from {mjx.__file__}")
