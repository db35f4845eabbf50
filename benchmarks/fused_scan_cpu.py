"""Is a ``lax.scan`` over training iterations slower than one iteration per call? (CPU check)

Times NPG on ``TASK`` with ``NUM_ENVS`` envs x 32 steps: 10 iterations as 10 calls of one
iteration, then as 2 calls of a 5-iteration scan (``jaxpg.train.compiled_block``), after compiling.

    python benchmarks/fused_scan_cpu.py cartpole 256
    python benchmarks/fused_scan_cpu.py inverted_pendulum 64
"""

import sys
import time

import jax

from jaxpg import envs, train
from jaxpg.algos import npg

task = sys.argv[1]
n = int(sys.argv[2])
env = envs.make(task)
cfg = npg.Config(num_envs=n, horizon=32, eval_envs=0, value_batch_size=n * 4)
ts = train._private_copy(npg.init(jax.random.PRNGKey(0), env, cfg))
for per in (1, 5):
    f = train.compiled_block(npg.update, per, False)
    ts, _ = jax.block_until_ready(f(ts))
    t = time.perf_counter()
    for _ in range(10 // per):
        ts, m = f(ts)
    jax.block_until_ready(ts)
    print(task, n, "per_call", per, f"{(time.perf_counter() - t) / 10 * 1e3:.1f} ms/iter", flush=True)
