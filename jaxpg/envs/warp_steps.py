"""Several MuJoCo Warp physics steps in one call from XLA.

MJX runs MuJoCo Warp's step as one XLA FFI call per physics step, and each call runs a Python
callback on the host: Warp's JAX bridge reads the call's buffers and launches the step's CUDA
graph. At a few hundred envs that callback, not the GPU, sets the step rate (BENCHMARKS.md,
"Where a warm run's time goes": about 0.44 ms of a 0.53 ms physics step for the card's Hopper).
``repeated_step(n)`` gives a function ``(model, data) -> data`` that runs ``n`` MuJoCo Warp steps
in one call: the callback runs the same step ``n`` times on the same buffers, so Warp captures
the ``n`` steps in one graph and a frame skip of ``n`` costs one callback instead of ``n``.

It is built from MJX 3.17's Warp bindings (``mujoco.mjx.warp.forward``: the step's FFI
wrapper ``_step_jax_impl``, the Warp function ``_step_shim`` it calls, and the marshalling
decorators of ``mujoco.mjx.warp.ffi``). These are MJX internals: ``repeated_step`` returns
``None`` when they are missing, and callers then loop over ``mjx.step`` as before. MJX's own
module is not modified: the wrapper is a copy of ``_step_jax_impl`` whose ``_step_shim`` is the
repeated one.
"""

from __future__ import annotations

import functools
import types
from collections.abc import Callable
from typing import Any

import jax


def _bindings() -> tuple[Any, Any] | None:
    """MJX's Warp ``ffi`` and ``forward`` modules, or ``None`` without them or their internals."""
    try:
        from mujoco.mjx.warp import ffi, forward
    except ImportError:
        return None
    wanted = [(forward, "_step_jax_impl"), (forward, "_step_shim")]
    wanted += [(ffi, "marshal_jax_warp_callable"), (ffi, "marshal_custom_vmap")]
    if not all(hasattr(module, name) for module, name in wanted):
        return None
    if not isinstance(forward._step_jax_impl, types.FunctionType):
        return None
    return ffi, forward


@functools.cache
def repeated_step(n: int) -> Callable[[Any, Any], Any] | None:
    """``(model, data) -> data`` after ``n`` MuJoCo Warp physics steps in one FFI call (the same
    as ``n`` calls of ``mjx.step``; usable under ``jit`` and nested ``vmap`` like ``mjx.step``),
    or ``None`` if this MJX lacks the internals it is built from."""
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    bindings = _bindings()
    if bindings is None:
        return None
    ffi, forward = bindings
    shim = forward._step_shim

    @functools.wraps(shim)  # Warp reads the buffers' types from the wrapped signature
    def shim_n_times(*args: Any) -> None:
        for _ in range(n):
            shim(*args)

    single = forward._step_jax_impl
    namespace = {**single.__globals__, "_step_shim": shim_n_times}
    impl = types.FunctionType(single.__code__, namespace, single.__name__, single.__defaults__, single.__closure__)

    @jax.custom_batching.custom_vmap
    @ffi.marshal_jax_warp_callable
    def step_n(m: Any, d: Any) -> Any:
        return impl(m, d)

    @step_n.def_vmap
    @ffi.marshal_custom_vmap
    def step_n_vmap(axis_size: int, is_batched: Any, m: Any, d: Any) -> tuple[Any, Any]:
        return step_n(m, d), is_batched[1]

    return step_n
