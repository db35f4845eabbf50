"""Why a timed ``lax.scan`` over iterations looked 10-17x slower: the timed call compiled again.

A ``TrainState`` built eagerly (``npg.init`` outside ``jit``) holds uncommitted arrays, except
MuJoCo Warp's buffers, which MJX commits to the device. The outputs of a jitted call are all
committed, and ``jit`` keeps one executable per mix of committed and uncommitted arguments. So
``block(state)`` compiles, and ``block(block(state)[0])`` compiles the same program a second time:
a benchmark that timed that second call measured a compilation. With the JAX implementation every
leaf is uncommitted, and the second call reuses the first executable.

This prints, per implementation, the executables in ``jit``'s cache and each call's time, for
an eager state and for one committed first (``jax.device_put``, as ``jaxpg.train`` does with a
jitted copy). Runs on the CPU (tiny batch) or the GPU.

    python benchmarks/scan_recompile.py --impl jax warp
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import jax


def calls(block: Any, state: Any, count: int) -> list[tuple[float, int]]:
    """``count`` chained calls; each call's seconds and the executables cached after it."""
    out = []
    for _ in range(count):
        start = time.perf_counter()
        state, _ = jax.block_until_ready(block(state))
        out.append((time.perf_counter() - start, block._cache_size()))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--impl", nargs="+", default=["jax", "warp"], choices=("jax", "warp"))
    parser.add_argument("--num-envs", type=int, default=4)
    parser.add_argument("--iterations", type=int, default=2, help="iterations in the scan")
    args = parser.parse_args()

    from jaxpg import envs, train
    from jaxpg.algos import npg

    rows = []
    for impl in args.impl:
        env = envs.make("hopper", batch=args.num_envs, impl=impl)
        config = npg.Config(num_envs=args.num_envs, horizon=8, eval_envs=0, value_batch_size=16)
        for start in ("eager", "committed"):
            state = npg.init(jax.random.PRNGKey(0), env, config)
            if start == "committed":
                state = jax.device_put(state, jax.devices()[0])
            block = jax.jit(lambda ts: train.scan_updates(npg.update, ts, args.iterations))
            rows.append((impl, start, calls(block, state, 3)))
    print(f"\n{jax.devices()[0].device_kind}, hopper, {args.num_envs} envs, scan of {args.iterations} NPG iterations")
    print("| impl | state | call 1 s (executables) | call 2 s (executables) | call 3 s (executables) |")
    print("|---|---|---|---|---|")
    for impl, start, timings in rows:
        cells = " | ".join(f"{seconds:.2f} ({cached})" for seconds, cached in timings)
        print(f"| {impl} | {start} | {cells} |")


if __name__ == "__main__":
    main()
