"""jaxpg's one process-wide XLA setting (``jaxpg/xla_flags.py``): one thread in XLA:CPU's pool
(``NPROC=1``), which keeps jaxlib 0.10's batched LAPACK calls from deadlocking the pool."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

from jaxpg import xla_flags

# As many independent batched Cholesky factorizations per step as the cores the process may use (at
# most 8: as many as XLA:CPU's pool would have threads), 1000 steps in a row, each batch large enough
# that jaxlib 0.10 splits it over the pool. On two cores with jaxlib 0.10.2 it never returned under
# XLA's default flags (4 of 4 runs), and hung 1 run in 6 under the memory-minimising schedule that
# jaxpg used to set; with NPROC=1, 10 of 10 returned, in 3-4 s. The factors are checked against NumPy's.
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
    print(os.environ.get("NPROC"), count, total)
    """
)


def test_one_thread_is_asked_for_once_and_a_users_own_setting_is_kept():
    environ: dict[str, str] = {}
    assert xla_flags.set_single_thread_cpu_pool(environ, "0.10.2") == "1" == environ["NPROC"]
    assert xla_flags.set_single_thread_cpu_pool(environ, "0.10.2") == "1" and len(environ) == 1
    mine = {"NPROC": "2", "XLA_FLAGS": "--xla_dump_to=/tmp/d"}
    assert xla_flags.set_single_thread_cpu_pool(mine, "0.10.2") == "2"
    assert mine == {"NPROC": "2", "XLA_FLAGS": "--xla_dump_to=/tmp/d"}


def test_only_the_jaxlibs_that_split_lapack_batches_get_it():
    """0.10.x and 0.11.0 hung without it; 0.11.1 and 0.11.2 did not (jaxpg/xla_flags.py)."""
    for version in ("0.11.1", "0.11.2", "0.12.0", "0.9.2", "0.1.0", ""):
        environ: dict[str, str] = {}
        assert xla_flags.set_single_thread_cpu_pool(environ, version) == "" and environ == {}
    for version in ("0.10.0", "0.10.2", "0.11.0"):
        assert xla_flags.set_single_thread_cpu_pool({}, version) == "1"


def test_an_option_is_added_once_and_a_users_own_value_is_kept():
    assert xla_flags.with_option("", "xla_b", "0") == "--xla_b=0"
    assert xla_flags.with_option("--xla_dump_to=/tmp/d", "xla_b", "0") == "--xla_dump_to=/tmp/d --xla_b=0"
    assert xla_flags.with_option("--xla_b=1", "xla_b", "0") == "--xla_b=1"
    assert xla_flags.with_options("--xla_b=1", [("xla_a", "2"), ("xla_b", "0")]) == "--xla_b=1 --xla_a=2"


def test_batched_cholesky_calls_side_by_side_return_after_import_jaxpg():
    """A fresh process that imports jaxpg runs the program that hung without the setting, and gets
    NumPy's factors (float32 against float64: entries of order 1-5, so 1e-4 holds rounding)."""
    environ = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", "NPROC")} | {"JAX_PLATFORMS": "cpu"}
    done = subprocess.run(
        [sys.executable, "-c", CHOLESKY_PROGRAM], env=environ, capture_output=True, text=True, timeout=180
    )
    assert done.returncode == 0, done.stderr[-2000:]
    if xla_flags.splits_lapack_batches(xla_flags.installed_jaxlib()):
        assert done.stdout.startswith("1 ")


def test_accepted_options_leaves_out_a_flag_xla_does_not_know():
    """A made-up flag would end any process that reads it in ``XLA_FLAGS``; ``accepted_options``
    tries each option in its own interpreter and keeps only the known one."""
    known = ("xla_backend_optimization_level", "1")
    assert xla_flags.accepted_options([("xla_no_such_flag_for_jaxpg", "true"), known]) == (known,)
