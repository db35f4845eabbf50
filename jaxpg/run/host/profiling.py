"""Where the time of one training iteration goes: each phase compiled and timed on its own (the
command line's ``--profile``).

A fused ``update`` is one program, so it has no phase timings of its own. An algorithm that
declares its phases (a module with ``PHASES`` and ``iteration(ts, run_phase)``, see
``jaxpg.algos.core.iteration``) can run one iteration as a sequence of separately jitted phases
instead: ``profile_phases`` hands it a ``run_phase`` that jits each phase and times it
(``jax.block_until_ready`` after each), once to compile them and once to time them. The phases are
the algorithm's own code, so the profiled iteration is the trained one. Phase timings include
dispatch; the fused ``update`` is faster than their sum. Host code: nothing here is traced into
the training loop.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from types import ModuleType
from typing import Any

import jax

from jaxpg import algos
from jaxpg.algos.core import TrainState
from jaxpg.envs import compile_options


def declares_phases(module: ModuleType) -> bool:
    """``module`` (an algorithm) writes its iteration as named phases (``PHASES``, ``iteration``)."""
    return hasattr(module, "PHASES") and hasattr(module, "iteration")


def phased_algorithms() -> list[str]:
    """The names of the algorithms that declare their phases (``--profile`` times those)."""
    return [name for name in sorted(algos.ALGORITHMS) if declares_phases(algos.get(name))]


def profile_phases(algo: str, ts: TrainState) -> tuple[TrainState, dict[str, float]]:
    """Run one iteration of ``algo`` (one of ``phased_algorithms()``) from ``ts`` as separately
    jitted phases and time each: ``(state after the iteration, {phase: seconds})`` in the order
    of the algorithm's ``PHASES``, measured after a warm-up iteration that compiles every phase.
    The state is the one ``update`` would give, up to the order of float operations."""
    module = algos.get(algo)
    if not declares_phases(module):
        raise ValueError(f"{algo} does not declare its phases; these do: {', '.join(phased_algorithms())}")
    jitted: dict[str, Callable[..., Any]] = {}

    def run(ts: TrainState) -> tuple[TrainState, dict[str, float]]:
        timings: dict[str, float] = {}

        def timed(name: str, phase: Callable[..., Any], *args: Any) -> Any:
            fn = jitted.setdefault(name, compile_options.jit(phase, ts.env))
            start = time.perf_counter()
            out = jax.block_until_ready(fn(*args))
            timings[name] = time.perf_counter() - start
            return out

        ts, _ = module.iteration(ts, timed)
        return ts, timings

    run(ts)  # compile every phase
    return run(ts)
