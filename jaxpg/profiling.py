"""Where the time of one training iteration goes: each phase compiled and timed on its own (the
command line's ``--profile``).

A fused ``update`` is one program, so it has no phase timings of its own. ``profile_phases``
runs one iteration of an algorithm that has an entry in ``PHASES`` as a sequence of separately
jitted phases instead (``jax.block_until_ready`` after each), once to compile them and once to
time them. Phase timings include dispatch; the fused ``update`` is faster than their sum. This is
host code: nothing here runs inside the jitted training loop.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import jax
from jax.flatten_util import ravel_pytree

from jaxpg.algos import core, natural_gradient, npg
from jaxpg.algos.core import TrainState

Timed = Callable[..., Any]
"""``timed(name, phase, *args) -> phase(*args)``: runs the jitted ``phase`` and records its time."""


def npg_phases(ts: TrainState, timed: Timed) -> TrainState:
    """One NPG iteration as LyceumAI reports its phases: ``sampling``, ``advantages`` (value
    predictions and GAE), ``gradient`` (the vanilla policy gradient), ``cg`` (the natural
    direction) and ``value_fit``; the normalised step between them is not timed (nor backtracked)."""
    old = ts
    ts, traj, key = timed("sampling", core.phase_sample, ts)
    value_key, _ = jax.random.split(key)
    batch = timed("advantages", core.phase_advantages, ts, traj)
    grad = timed("gradient", natural_gradient.phase_gradient, ts, batch)
    cg = timed("cg", natural_gradient.phase_natural_gradient, ts, batch, grad)
    step = npg.normalized_step(grad, cg.x, ts.config.kl_delta)
    flat_params, unravel = ravel_pytree(ts.params)
    ts = ts.replace(params=unravel(flat_params + step * cg.x))
    ts, _ = timed("value_fit", core.phase_value_fit, ts, batch, value_key)
    return ts.replace(iteration=old.iteration + 1)


# Algorithm name -> one iteration of it as timed phases.
PHASES: dict[str, Callable[[TrainState, Timed], TrainState]] = {"npg": npg_phases}


def profile_phases(algo: str, ts: TrainState) -> tuple[TrainState, dict[str, float]]:
    """Run one iteration of ``algo`` (a key of ``PHASES``) from ``ts`` as separately jitted phases
    and time each: ``(state after the iteration, {phase: seconds})``, measured after a warm-up
    iteration that compiles every phase."""
    iteration = PHASES[algo]
    jitted: dict[str, Callable] = {}

    def run(ts: TrainState) -> tuple[TrainState, dict[str, float]]:
        timings: dict[str, float] = {}

        def timed(name: str, phase: Callable, *args: Any) -> Any:
            fn = jitted.setdefault(name, jax.jit(phase))
            start = time.perf_counter()
            out = jax.block_until_ready(fn(*args))
            timings[name] = time.perf_counter() - start
            return out

        return iteration(ts, timed), timings

    run(ts)  # compile every phase
    return run(ts)
