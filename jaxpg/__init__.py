"""jaxpg: JAX-native policy-gradient training on MuJoCo MJX."""

from __future__ import annotations

from typing import Any

from jaxpg.xla_flags import set_sequential_cpu_schedule

# XLA:CPU's memory-minimising schedule, before JAX starts a backend: jaxlib 0.10's batched LAPACK
# calls can deadlock XLA's thread pool under the concurrency-optimised one (jaxpg/xla_flags.py).
set_sequential_cpu_schedule()

__version__ = "0.1.0"

__all__ = ["load_policy"]


def __getattr__(name: str) -> Any:
    # ``jaxpg.load_policy`` imports JAX only when first used, so that ``import jaxpg`` stays cheap.
    if name == "load_policy":
        from jaxpg.run.policy_io import load_policy

        return load_policy
    raise AttributeError(f"module 'jaxpg' has no attribute {name!r}")
