"""``card_command.py capture``: Warp's CUDA-graph capture with and without an XLA compilation beside it."""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from typing import Any

import harness

RAW = argparse.RawDescriptionHelpFormatter


CAPTURE_DOC = """Does an XLA compilation on another thread break MuJoCo Warp's CUDA-graph capture?

MJX runs a MuJoCo Warp physics step as an XLA FFI call, and Warp captures the step into a CUDA
graph the first time it sees a call's buffers. This steps 256 Walker2d envs (a jitted scan of 8
env steps per call; the last 200 outputs are kept alive, so later calls get new buffers and Warp
captures again) for ``--seconds``, first alone, then with a thread compiling XLA programs beside
it, and prints whether the stepping survived.

On the GPU, stepping with a compiling thread failed with ``Warp CUDA error 904: capturing stream
has unjoined work`` while stepping alone passed (``docs/benchmarks_archive.md``, "The suite within
1 M env steps"). Training runs sharing a GPU failed the same way (CUDA error 901) while their evaluation program
compiled on a background thread; ``jaxpg.train.train`` now compiles nothing while a MuJoCo Warp
program runs. Needs a GPU: on the CPU Warp captures no graphs.

    python benchmarks/card_command.py capture --seconds 60 --json capture.json
"""
CAPTURE_ENVS = 256


def keep_compiling(stop: Any, count: list[int]) -> None:
    """Compile a new small XLA program (a matrix product of a new size) until ``stop`` is set."""
    import jax
    import jax.numpy as jnp

    size = 256
    while not stop.is_set():
        program = jax.jit(lambda a, b: jnp.tanh(a @ b) @ b.T + jnp.sort(a, axis=0))
        spec = jax.ShapeDtypeStruct((size, size), jnp.float32)
        program.lower(spec, spec).compile()
        count[0] += 1
        size += 8


def step_for(seconds: float, compile_beside: bool) -> dict[str, Any]:
    """Step the envs for ``seconds``, with or without a compiling thread: calls, compilations,
    seconds and the error that stopped the stepping (``None``: none)."""
    import threading

    import jax

    from jaxpg import envs

    env = envs.make("walker2d", impl="warp", batch=CAPTURE_ENVS)

    def body(states: Any, key: jax.Array) -> tuple[Any, None]:
        actions = jax.random.uniform(key, (CAPTURE_ENVS, env.action_size), minval=-1.0, maxval=1.0)
        return jax.vmap(env.step)(states, actions), None

    roll = jax.jit(lambda states, key: jax.lax.scan(body, states, jax.random.split(key, 8))[0])
    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), CAPTURE_ENVS))
    states = jax.block_until_ready(roll(states, jax.random.key(0)))  # compiled and captured once
    stop, count = threading.Event(), [0]
    compiler = threading.Thread(target=keep_compiling, args=(stop, count), daemon=True)
    if compile_beside:
        compiler.start()
    kept: list[Any] = []
    calls, error, start = 0, None, time.perf_counter()
    try:
        while time.perf_counter() - start < seconds:
            states = jax.block_until_ready(roll(states, jax.random.key(calls + 1)))
            kept = [*kept[-200:], states]  # alive: the next calls get new buffers, captured anew
            calls += 1
    except Exception as e:  # noqa: BLE001 - the error is the measurement
        error = str(e).splitlines()[0][:200]
    stop.set()
    if compile_beside:
        compiler.join()  # exiting during a compilation aborts the process
    return {
        "compiling_thread": compile_beside,
        "calls": calls,
        "compilations": count[0],
        "seconds": time.perf_counter() - start,
        "error": error,
    }


def capture_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="card_command.py capture", description=CAPTURE_DOC, formatter_class=RAW)
    parser.add_argument("--seconds", type=float, default=60.0, help="stepping time of each setting (default: 60)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    rows = [step_for(args.seconds, False), step_for(args.seconds, True)]
    harness.write_json(args.json, rows, argv=list(argv))
    print(f"\n{harness.describe()}")
    print(
        harness.table(
            rows,
            [
                ("compiling thread", lambda r: "yes" if r["compiling_thread"] else "no"),
                ("calls", lambda r: r["calls"]),
                ("compilations", lambda r: r["compilations"]),
                ("seconds", lambda r: f"{r['seconds']:.0f}"),
                ("error", lambda r: r["error"] or "none"),
            ],
        )
    )
