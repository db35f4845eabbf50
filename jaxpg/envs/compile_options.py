"""XLA compile options that the programs stepping a task need: ``jit(fun, env)``.

XLA:CPU's fusion emitters (the default in JAX 0.10) emit a fused computation as one function per
subgraph, called again for every element a consumer reads, without reusing results. MJX's
kinematic pass fuses each level of the body tree with the levels above it (every level's frame is a
product of its parent's), so along a chain of hinged bodies these calls multiply level by level: the
run time grows exponentially with the chain's depth while the code stays small. Pusher's arm (seven
hinges in a chain ten bodies deep) runs ``mjx.kinematics`` orders of magnitude slower than Hopper,
and more so vmapped. The legacy emitters (``xla_cpu_use_fusion_emitters=False``) compute each
element once, at about Hopper's cost. A task whose chain is that deep sets ``cpu_fusion_emitters = False``
(``MjxEnv``), and every program that steps it is compiled with the legacy emitters when it runs on
the CPU with MJX's JAX implementation. Other tasks keep XLA's defaults, which run their steps faster
(measured on Hopper and Reacher on two CPU cores). The option is an ordinary compile
option of that one program, not a process-wide flag; a jaxlib without it compiles with the defaults.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import jax

# XLA's legacy CPU emitters in place of its fusion emitters (see the module docstring).
LEGACY_CPU_EMITTERS: tuple[tuple[str, Any], ...] = (("xla_cpu_use_fusion_emitters", False),)


def compiler_options(env: Any) -> tuple[tuple[str, Any], ...]:
    """The compile options (``(name, value)`` pairs; hashable) of programs that step ``env``.

    ``LEGACY_CPU_EMITTERS`` for a task (or a wrapper of one) with ``cpu_fusion_emitters`` false on
    MJX's JAX implementation, when JAX's default backend is the CPU and this jaxlib knows the
    option; else none (``()``)."""
    if getattr(env, "cpu_fusion_emitters", True) or getattr(env, "impl", None) != "jax":
        return ()
    if jax.default_backend() != "cpu" or not _accepted(LEGACY_CPU_EMITTERS):
        return ()
    return LEGACY_CPU_EMITTERS


@functools.cache
def _accepted(options: tuple[tuple[str, Any], ...]) -> bool:
    """Whether XLA accepts ``options`` (it rejects a name it does not know), tried on a tiny program."""
    try:
        jax.jit(lambda x: x + 1, compiler_options=dict(options)).lower(0.0).compile()
    except Exception:  # noqa: BLE001 - an unknown option: compile with the defaults
        return False
    return True


def jit(fun: Callable, env: Any, options: tuple[tuple[str, Any], ...] | None = None, **kwargs: Any) -> Callable:
    """``jax.jit(fun, **kwargs)`` with the compile options of programs that step ``env``
    (``compiler_options(env)``, or ``options`` when given)."""
    options = compiler_options(env) if options is None else options
    return jax.jit(fun, compiler_options=dict(options) if options else None, **kwargs)
