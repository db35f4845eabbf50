"""The env batch sharded over several devices trains like one device.

Runs in a subprocess with ``XLA_FLAGS=--xla_force_host_platform_device_count=4`` (the device count
is fixed when JAX starts). NPG on ``cartpole`` for 3 iterations, once on one device and once with
``env_state`` sharded over 4 devices (``jaxpg.cli.shard_state``), must give the same metrics up to
float reduction order: every reduction (advantage normalisation, gradients, Fisher-vector
products, value fit, metrics) is global under ``jit``, so only the order of summation differs.
Tolerance: rtol 1e-4 on the first iteration, 2e-2 on the update diagnostics after it (conjugate
gradient in float32 amplifies last-bit differences).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent(
    """
    import json
    import jax
    import numpy as np
    import jaxpg.envs as envs
    from jaxpg import train
    from jaxpg.algos import npg
    from jaxpg.cli import shard_state

    assert len(jax.devices()) == 4, jax.devices()
    env = envs.make("cartpole")
    config = npg.Config(num_envs=16, horizon=32, eval_envs=4, eval_horizon=64, value_batch_size=64, cg_damping=1e-2)
    block = jax.jit(lambda ts: train.scan_updates(npg.update, ts, 3))
    _, single = block(npg.init(jax.random.PRNGKey(0), env, config))
    sharded_state = shard_state(npg.init(jax.random.PRNGKey(0), env, config), vmap_seeds=False)
    assert len(sharded_state.env_state.obs.sharding.device_set) == 4
    _, sharded = block(sharded_state)
    out = {k: [np.asarray(single[k]).tolist(), np.asarray(sharded[k]).tolist()] for k in single}
    print("RESULT " + json.dumps(out))
    """
)


def test_sharded_npg_matches_single_device():
    env = {**os.environ, "XLA_FLAGS": "--xla_force_host_platform_device_count=4", "JAX_PLATFORMS": "cpu"}
    proc = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, env=env, timeout=900)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stderr[-3000:]
    metrics = json.loads(lines[0][len("RESULT ") :])
    import numpy as np

    for key, (single, sharded) in metrics.items():
        single, sharded = np.array(single, dtype=float), np.array(sharded, dtype=float)
        if key == "cg_residual":
            continue
        np.testing.assert_allclose(sharded[0], single[0], rtol=1e-4, atol=1e-5, err_msg=key)
    for key in ("kl", "value_loss", "grad_norm", "step_size", "return_stochastic"):
        single, sharded = (np.array(x, dtype=float) for x in metrics[key])
        np.testing.assert_allclose(sharded, single, rtol=2e-2, atol=1e-4, err_msg=key)
