"""jaxpg's one process-wide XLA setting (``jaxpg/xla_flags.py``): XLA:CPU's memory-minimising
schedule, which keeps jaxlib 0.10's batched LAPACK calls from deadlocking XLA's thread pool."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

from jaxpg import xla_flags

# As many independent batched Cholesky factorizations per step as XLA:CPU's thread pool has threads
# (at most 8), 1000 steps in a row, each batch large enough that jaxlib 0.10 splits it over the pool.
# Without the flag this program never returned on two cores (3 runs of 3; 50 steps: 1 of 3); with
# it, 5 of 5 returned. The factors are checked against NumPy's.
CHOLESKY_PROGRAM = textwrap.dedent(
    """
    import os
    import jaxpg  # sets XLA_FLAGS before JAX starts its backend
    import jax, jax.numpy as jnp, numpy as np
    count = min(len(os.sched_getaffinity(0)), 8)
    x = np.random.default_rng(0).normal(size=(count, 4096, 6, 6)).astype(np.float32)
    spd = x @ np.swapaxes(x, -1, -2) + 6.0 * np.eye(6, dtype=np.float32)
    @jax.jit
    def run(mats):
        def step(total, _):
            factors = [jnp.linalg.cholesky(mats[i] * (1.0 + 1e-9 * total)) for i in range(count)]
            return total + sum(f[:, 0, 0].mean() for f in factors), None
        total = jax.lax.scan(step, jnp.float32(0.0), None, length=1000)[0]
        return total, jnp.stack([jnp.linalg.cholesky(mats[i]) for i in range(count)])
    total, factors = jax.device_get(run(jnp.asarray(spd)))
    np.testing.assert_allclose(factors, np.linalg.cholesky(spd.astype(np.float64)), rtol=1e-4, atol=1e-4)
    print(os.environ["XLA_FLAGS"], count, total)
    """
)


def test_the_flag_is_added_once_and_a_users_own_setting_is_kept():
    assert xla_flags.with_sequential_cpu_schedule("") == xla_flags.FLAG
    assert xla_flags.with_option("--xla_dump_to=/tmp/d", "xla_b", "0") == "--xla_dump_to=/tmp/d --xla_b=0"
    assert xla_flags.with_option("--xla_b=1", "xla_b", "0") == "--xla_b=1"
    assert xla_flags.with_sequential_cpu_schedule("--xla_dump_to=/tmp/d") == f"--xla_dump_to=/tmp/d {xla_flags.FLAG}"
    mine = "--xla_cpu_enable_concurrency_optimized_scheduler=true"
    assert xla_flags.with_sequential_cpu_schedule(mine) == mine
    environ = {"XLA_FLAGS": "--xla_dump_to=/tmp/d"}
    once = xla_flags.set_sequential_cpu_schedule(environ, "0.10.2")
    assert xla_flags.set_sequential_cpu_schedule(environ, "0.10.2") == once == environ["XLA_FLAGS"]
    assert environ["XLA_FLAGS"].count(xla_flags.OPTION) == 1


def test_only_jaxlib_0_10_gets_the_flag():
    """XLA aborts on a flag it does not know, so only the jaxlib known to deadlock gets it."""
    for version in ("0.11.2", "0.9.2", ""):
        environ: dict[str, str] = {}
        assert xla_flags.set_sequential_cpu_schedule(environ, version) == "" and environ == {}
    assert xla_flags.set_sequential_cpu_schedule({}, "0.10.0") == xla_flags.FLAG


def test_batched_cholesky_calls_side_by_side_return_after_import_jaxpg():
    """A fresh process that imports jaxpg runs the program that hung without the flag, and gets
    NumPy's factors (float32 against float64: entries of order 1-5, so 1e-4 holds rounding)."""
    environ = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"} | {"JAX_PLATFORMS": "cpu"}
    done = subprocess.run(
        [sys.executable, "-c", CHOLESKY_PROGRAM], env=environ, capture_output=True, text=True, timeout=180
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith(xla_flags.FLAG)
