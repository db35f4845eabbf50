"""Does an XLA compilation on another thread break MuJoCo Warp's CUDA-graph capture?

MJX runs a MuJoCo Warp physics step as an XLA FFI call, and Warp captures the step into a CUDA
graph the first time it sees a call's buffers. This steps 256 Walker2d envs (a jitted scan of 8
env steps per call, each call's output kept alive so that later calls get new buffers and Warp
captures again) for ``--seconds``, once with a thread compiling XLA programs meanwhile and once
without, and prints whether the stepping survived:

    python benchmarks/warp_capture.py --seconds 60

On one H200 (2026-11-27) the run with a compiling thread failed after 74 calls (3 s) with
``Warp CUDA error 904: capturing stream has unjoined work``; without it, 899 calls in 30 s
passed. Training runs that shared a GPU failed the same way (CUDA error 901) while their
evaluation program compiled on a background thread; ``jaxpg.train.train`` now compiles nothing
while a MuJoCo Warp program runs. Needs a GPU: on the CPU Warp captures no graphs.
"""

from __future__ import annotations

import argparse
import threading
import time

import harness
import jax
import jax.numpy as jnp

from jaxpg import envs

ENVS = 256
STEPS_PER_CALL = 8
KEPT = 200  # outputs kept alive: later calls get new buffers, which Warp captures anew


def keep_compiling(stop: threading.Event, count: list[int]) -> None:
    """Compile a new small XLA program (a matrix product of a new size) until ``stop`` is set."""
    size = 256
    while not stop.is_set():
        program = jax.jit(lambda a, b: jnp.tanh(a @ b) @ b.T + jnp.sort(a, axis=0))
        spec = jax.ShapeDtypeStruct((size, size), jnp.float32)
        program.lower(spec, spec).compile()
        count[0] += 1
        size += 8


def step_for(seconds: float, compile_beside: bool) -> dict:
    """Step the envs for ``seconds``, with or without a compiling thread: calls, compilations,
    seconds and the error that stopped it (``None``: none)."""
    env = envs.make("walker2d", impl="warp", batch=ENVS)

    @jax.jit
    def roll(states: envs.State, key: jax.Array) -> envs.State:
        def body(states: envs.State, k: jax.Array) -> tuple[envs.State, None]:
            actions = jax.random.uniform(k, (ENVS, env.action_size), minval=-1.0, maxval=1.0)
            return jax.vmap(env.step)(states, actions), None

        return jax.lax.scan(body, states, jax.random.split(key, STEPS_PER_CALL))[0]

    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), ENVS))
    states = jax.block_until_ready(roll(states, jax.random.key(0)))  # compiled and captured once
    stop, count = threading.Event(), [0]
    if compile_beside:
        threading.Thread(target=keep_compiling, args=(stop, count), daemon=True).start()
    kept, calls, error, start = [], 0, None, time.perf_counter()
    try:
        while time.perf_counter() - start < seconds:
            states = jax.block_until_ready(roll(states, jax.random.key(calls + 1)))
            kept = [*kept[-KEPT:], states]
            calls += 1
    except Exception as e:  # noqa: BLE001 - the error is the measurement
        error = str(e).splitlines()[0][:200]
    stop.set()
    return {"compiling thread": compile_beside, "calls": calls, "compilations": count[0],
            "seconds": time.perf_counter() - start, "error": error}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=60.0, help="stepping time of each setting")
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    rows = [step_for(args.seconds, False), step_for(args.seconds, True)]
    harness.write_json(args.json, rows)
    print(harness.describe())
    columns = [(name, lambda r, n=name: r[n]) for name in ("compiling thread", "calls", "compilations")]
    columns += [("seconds", lambda r: f"{r['seconds']:.0f}"), ("error", lambda r: r["error"] or "none")]
    print(harness.table(rows, columns))


if __name__ == "__main__":
    main()
