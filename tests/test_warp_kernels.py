"""The background build of MuJoCo Warp's kernels: its dry run finds the modules a physics step
launches and leaves Warp as it found it; off a GPU it does nothing."""

from __future__ import annotations

import pytest

import jaxpg.envs as envs
from jaxpg.envs.mjx_env import warp_available
from jaxpg.envs.warp_kernels import KernelBuild, step_modules

pytestmark = pytest.mark.skipif(not warp_available(), reason="warp-lang is not installed (pip install 'jaxpg[warp]')")


def test_dry_run_finds_the_step_modules_and_restores_warp():
    """Hopper's step launches kernels of MuJoCo Warp's solver, smooth and forward modules and of
    per-model modules built for it (34 modules loaded at first execution on a GPU); the dry run
    puts Warp's launch functions back."""
    import warp as wp

    before = (wp.launch, wp.launch_tiled, wp.capture_if, wp.capture_while)
    task = envs.make_task("hopper", impl="warp", max_batch=2)
    loads = step_modules(task.mj_model, int(task._data0._impl.naconmax), int(task._data0._impl.njmax))
    assert (wp.launch, wp.launch_tiled, wp.capture_if, wp.capture_while) == before
    names = {module.name for module, _ in loads}
    for part in ("solver", "smooth", "forward", "passive", "constraint"):
        assert any(name.endswith(f"mujoco_warp._src.{part}") for name in names), (part, sorted(names))
    assert sum("__locals__" in name for name in names) >= 20, sorted(names)  # kernels made for this model


def test_build_does_nothing_off_a_gpu_or_on_mjx_jax():
    for impl in ("jax", "warp"):
        build = KernelBuild.start(envs.make("hopper", impl=impl, batch=2))
        build.wait()
        assert build.modules == 0 and build.error is None
