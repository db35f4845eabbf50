"""jaxpg: JAX-native policy-gradient training on MuJoCo MJX."""

from __future__ import annotations

from typing import Any

from jaxpg.xla_flags import set_single_thread_cpu_pool

# One thread in XLA:CPU's pool, before JAX starts a backend: jaxlib 0.10's batched LAPACK calls
# can otherwise deadlock the pool (jaxpg/xla_flags.py).
set_single_thread_cpu_pool()

__version__ = "0.1.0"

__all__ = ["load_policy", "sweep"]


def __getattr__(name: str) -> Any:
    # ``jaxpg.load_policy`` imports JAX only when first used, so that ``import jaxpg`` stays cheap.
    if name == "load_policy":
        from jaxpg.run.checkpoints.policy_io import load_policy

        return load_policy
    if name == "sweep":  # ``jaxpg.sweep(spec, out_dir)``, the callable module (docs/sweeps.md)
        import importlib

        return importlib.import_module("jaxpg.sweep")
    raise AttributeError(f"module 'jaxpg' has no attribute {name!r}")
