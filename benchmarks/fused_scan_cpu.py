"""Is a ``lax.scan`` over training iterations slower than one iteration per call? (CPU check)

Times NPG on a task with ``num_envs`` envs x 32 steps: 10 iterations as 10 calls of one
iteration, then as 2 calls of a 5-iteration scan (``jaxpg.train.compiled_block``), after compiling.

    python benchmarks/fused_scan_cpu.py cartpole 256
    python benchmarks/fused_scan_cpu.py inverted_pendulum 64
"""

from __future__ import annotations

import sys
import time

import jax

from jaxpg import envs, train
from jaxpg.algos import npg


def ms_per_iteration(task: str, num_envs: int, per_call: int, iterations: int = 10) -> float:
    """Milliseconds per NPG iteration when ``per_call`` iterations run in one compiled scan."""
    env = envs.make(task)
    config = npg.Config(num_envs=num_envs, horizon=32, eval_envs=0, value_batch_size=num_envs * 4)
    ts = train.own_buffers(npg.init(jax.random.PRNGKey(0), env, config))
    block = train.compiled_block(npg.update, per_call, False)
    ts, _ = jax.block_until_ready(block(ts))  # compile
    start = time.perf_counter()
    for _ in range(iterations // per_call):
        ts, _ = block(ts)
    jax.block_until_ready(ts)
    return (time.perf_counter() - start) / iterations * 1e3


def main() -> None:
    task, num_envs = sys.argv[1], int(sys.argv[2])
    for per_call in (1, 5):
        print(
            f"{task} {num_envs} envs: {per_call} iteration(s) per call: "
            f"{ms_per_iteration(task, num_envs, per_call):.1f} ms per iteration",
            flush=True,
        )


if __name__ == "__main__":
    main()
