"""Build MuJoCo Warp's kernels for a task on all host cores, in the background, before they are needed.

MuJoCo Warp compiles each kernel module the first time a kernel of it is launched, and MJX launches
them from the first *execution* of a program that steps the physics, one after another. For
Hopper that is a few dozen modules, the largest part of a first run's start on a fresh machine
(docs/benchmarks_archive.md, section AW). ``KernelBuild.start(env)`` finds the modules a physics step launches by
a dry run of MuJoCo Warp's ``step`` on one world with its launches recorded instead of run (under a
second), then loads them on a pool of threads, where NVRTC and the CUDA driver compile them in
parallel, while the caller compiles its XLA programs. ``wait()`` before the
first program that steps the physics runs. Modules that the dry run missed are built at that first
execution, as without it; with Warp's kernel cache already filled the same loads read the cache.

Nothing here is needed for correctness: a task on MJX's JAX implementation, a CPU, a MuJoCo Warp
version whose ``step`` the dry run cannot follow, all give a build that does nothing.
"""

from __future__ import annotations

import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import jax

from jaxpg.envs.base import Env

ModuleLoad = tuple[Any, Any]  # (warp Module, block_dim or None: the module's default)


def step_modules(mj_model: Any, naconmax: int, njmax: int) -> list[ModuleLoad]:
    """The Warp modules (with the block size of each launch) that one MuJoCo Warp ``step`` of
    ``mj_model`` launches: the step run on one world with ``wp.launch``, ``wp.launch_tiled``,
    ``wp.capture_if`` and ``wp.capture_while`` replaced by recorders (both branches of a
    condition, one turn of a loop), so that nothing is compiled or run. Must not run while
    another thread launches Warp kernels."""
    # Imported here: jaxpg imports without warp-lang, and MJX's JAX implementation needs neither.
    import warp as wp
    from mujoco.mjx.third_party import mujoco_warp as mjw

    model = mjw.put_model(mj_model)
    data = mjw.make_data(mj_model, nworld=1, naconmax=naconmax, njmax=njmax)
    found: dict[tuple[int, Any], ModuleLoad] = {}

    def record(kernel: Any, *args: Any, **kwargs: Any) -> None:
        block_dim = kwargs.get("block_dim")
        found[(id(kernel.module), block_dim)] = (kernel.module, block_dim)

    def both_branches(condition: Any, on_true: Any = None, on_false: Any = None, stream: Any = None, **kw: Any) -> None:
        for branch in (on_true, on_false):
            if callable(branch):
                branch(**kw)

    def one_turn(condition: Any, while_body: Any, stream: Any = None, **kw: Any) -> None:
        while_body(**kw)

    saved = (wp.launch, wp.launch_tiled, wp.capture_if, wp.capture_while)
    wp.launch, wp.launch_tiled, wp.capture_if, wp.capture_while = record, record, both_branches, one_turn
    try:
        mjw.step(model, data)
    finally:
        wp.launch, wp.launch_tiled, wp.capture_if, wp.capture_while = saved
    return list(found.values())


class KernelBuild:
    """Warp kernel modules being built on a thread pool; ``wait()`` blocks until they are.

    ``seconds`` is the build's wall clock once done; ``modules`` how many it loaded; ``error`` the
    exception that stopped it (the modules are then built at first use, as without a build).
    """

    def __init__(self, loads: list[ModuleLoad], devices: list[str], workers: int):
        self.modules = len(loads) * len(devices)
        self.seconds: float | None = None
        self.error: BaseException | None = None
        self._thread = threading.Thread(
            target=self._run, args=(loads, devices, workers), name="jaxpg-warp-kernels", daemon=True
        )
        if loads and devices:
            self._thread.start()

    @classmethod
    def start(cls, env: Env, workers: int | None = None) -> KernelBuild:
        """Start building the kernels of ``env``'s physics step (any wrapper around an ``MjxEnv``
        on MuJoCo Warp and a GPU; otherwise a build that does nothing). Call it when no other
        thread launches Warp kernels; ``workers``: threads (default: the host's cores)."""
        task = env.unwrapped
        if getattr(task, "impl", None) != "warp":
            return cls([], [], 0)
        devices = _cuda_devices()
        if not devices:
            return cls([], [], 0)
        try:
            impl = task._data0._impl
            loads = step_modules(task.mj_model, int(impl.naconmax), int(impl.njmax))
        except Exception as e:  # a MuJoCo Warp this dry run cannot follow: build at first use instead
            build = cls([], [], 0)
            build.error = e
            return build
        return cls(loads, devices, workers or os.cpu_count() or 1)

    def _run(self, loads: list[ModuleLoad], devices: list[str], workers: int) -> None:
        start = time.perf_counter()
        try:
            jobs = [(module, block_dim, device) for device in devices for module, block_dim in loads]
            with ThreadPoolExecutor(max_workers=workers) as pool:
                list(pool.map(lambda job: job[0].load(job[2], job[1]), jobs))
        except BaseException as e:  # kept in ``error``; the kernels are then built at first use
            self.error = e
        self.seconds = time.perf_counter() - start

    def wait(self) -> None:
        """Block until the build has finished (at once if it never started)."""
        if self._thread.is_alive():
            self._thread.join()


def _cuda_devices() -> list[str]:
    """Warp's names (``cuda:N``) of the GPUs JAX computes on in this process; ``[]`` without any."""
    if jax.default_backend() != "gpu":
        return []
    return [f"cuda:{device.local_hardware_id}" for device in jax.local_devices() if device.platform == "gpu"]
