"""The env batch split over several devices trains like one device.

The device count is fixed when JAX starts, so the multi-device checks run in subprocesses with
``XLA_FLAGS=--xla_force_host_platform_device_count=4`` (or 2). NPG on ``cartpole``, once on one
device and once with the state on a 4-device mesh (``jaxpg.distributed.shard_state``) and ``update``
traced on it (``jaxpg.distributed.on_mesh``): sampling and evaluation then run under
``jax.shard_map``, each device stepping its own envs, and the learning side under jit's
partitioner. Both must give the same metrics up to float reduction order.

Why equal: the sampled actions are those of the unsplit batch bit for bit (each device draws the
noise of the whole batch and keeps its rows, ``core.sampling.sample_rows``; resets use the same split
keys), and every reduction (advantage normalisation, gradients, Fisher-vector products, value fit,
metrics) is global, so only the order of float32 summation differs.
Tolerances: rtol 1e-4 (atol 1e-5) on every metric of the first iteration, rtol 1e-2 on the later
ones (conjugate gradient in float32 amplifies last-bit differences of the gradient into the step,
which the next iterations inherit); the CG residual, a number near zero, is not compared. Measured
(printed with ``-s``): at most about 1e-5 relative on the first iteration, 2e-3 (a KL) by the
third; the returns identical.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import numpy as np
import pytest

import jaxpg.envs as envs
from jaxpg import rollout as rollout_lib
from jaxpg.algos import core, npg
from jaxpg.envs.mjx_env import warp_available

ROOT = Path(__file__).resolve().parents[1]

CARTPOLE_SCRIPT = textwrap.dedent(
    """
    import json
    import jax
    import numpy as np
    import jaxpg.envs as envs
    from jaxpg import distributed, train
    from jaxpg.algos import npg
    from jaxpg.distributed import shard_state

    assert len(jax.devices()) == 4, jax.devices()
    mesh = distributed.env_mesh()
    env = envs.make("cartpole")
    cases = {
        # eval_envs 6 over 4 devices: padded to 8, the 2 extra episodes left out of the means
        "continuing_seeds": (npg.Config(num_envs=16, horizon=32, eval_envs=6, eval_horizon=64, value_batch_size=64,
                                        cg_damping=1e-2), True),
        "episodic": (npg.Config(num_envs=8, horizon=48, sampling="episodic", eval_envs=4, eval_horizon=48,
                                value_batch_size=64, cg_damping=1e-2), False),
    }
    out = {}
    for name, (config, seeds) in cases.items():
        def init():
            if seeds:
                return train.init_seeds(npg.init, [0, 1], env, config)
            return npg.init(jax.random.PRNGKey(0), env, config)

        step = jax.vmap(npg.update) if seeds else npg.update
        _, single = jax.jit(lambda ts: train.scan_updates(step, ts, 3))(init())
        sharded_step = distributed.on_mesh(step, mesh)
        block = jax.jit(lambda ts: train.scan_updates(sharded_step, ts, 3))
        state = shard_state(init(), vmap_seeds=seeds, mesh=mesh)
        assert len(state.env_state.obs.sharding.device_set) == 4
        assert "shard_map" in str(jax.make_jaxpr(sharded_step)(state)), "sampling is not under shard_map"
        state, sharded = block(state)
        assert len(state.env_state.obs.sharding.device_set) == 4
        out[name] = {k: [np.asarray(single[k]).tolist(), np.asarray(sharded[k]).tolist()] for k in single}

    # a batch that does not split over the devices is refused with one line
    bad = npg.init(jax.random.PRNGKey(0), env, npg.Config(num_envs=6, horizon=8, value_batch_size=8, eval_envs=0))
    try:
        jax.jit(distributed.on_mesh(npg.update, mesh))(bad)
        out["indivisible"] = "no error"
    except ValueError as e:
        out["indivisible"] = str(e)
    print("RESULT " + json.dumps(out))
    """
)

WARP_SCRIPT = textwrap.dedent(
    """
    import json
    import jax
    import numpy as np
    import warp
    import jaxpg.envs as envs
    from jaxpg import distributed
    from jaxpg.algos import core, npg
    from jaxpg.distributed import shard_state

    warp.config.quiet = True
    assert len(jax.devices()) == 2, jax.devices()
    # each device steps 2 of the 4 envs, with its own contact buffer (sized for the unsplit reference)
    env = envs.make("inverted_pendulum", impl="warp", max_batch=4, max_episode_steps=6)
    config = npg.Config(num_envs=4, horizon=8, eval_envs=2, eval_horizon=8, value_batch_size=8)
    ts = npg.init(jax.random.PRNGKey(0), env, config)
    mesh = distributed.env_mesh()

    def run(ts):
        ts, traj, _ = core.phase_sample(ts)
        return ts.env_state.obs, traj.obs, traj.rewards, traj.dones, core.evaluate(ts, ts.key)

    single = jax.jit(run)(ts)
    sharded = jax.jit(distributed.on_mesh(run, mesh))(shard_state(ts, vmap_seeds=False, mesh=mesh))
    assert len(sharded[0].sharding.device_set) == 2
    assert "shard_map" in str(jax.make_jaxpr(distributed.on_mesh(run, mesh))(ts))
    diff = {
        "state_obs": float(np.max(np.abs(np.asarray(single[0]) - np.asarray(sharded[0])))),
        "obs": float(np.max(np.abs(np.asarray(single[1]) - np.asarray(sharded[1])))),
        "rewards": float(np.max(np.abs(np.asarray(single[2]) - np.asarray(sharded[2])))),
        "dones_equal": bool(np.array_equal(np.asarray(single[3]), np.asarray(sharded[3]))),
        "any_done": bool(np.asarray(single[3]).any()),
        "eval_return": abs(float(single[4]["episode_return"]) - float(sharded[4]["episode_return"])),
    }
    print("RESULT " + json.dumps(diff))
    """
)


def run_devices(script: str, devices: int) -> dict:
    """Run ``script`` in a fresh CPU process with ``devices`` forced host devices; its ``RESULT`` line."""
    env = {
        **os.environ,
        "XLA_FLAGS": f"--xla_force_host_platform_device_count={devices}",
        "JAX_PLATFORMS": "cpu",
    }
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=900)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stderr[-3000:]
    return json.loads(lines[0][len("RESULT ") :])


def test_sharded_npg_matches_single_device():
    """NPG on cartpole, 1 device vs the env batch split over 4 (continuing sampling with two
    vmapped seeds; episodic sampling), and the one-line error for an indivisible batch."""
    result = run_devices(CARTPOLE_SCRIPT, 4)
    assert "num_envs 6 is not divisible by the 4 devices" in result.pop("indivisible")
    arrays = {
        case: {
            key: tuple(np.array(x, dtype=float) for x in pair) for key, pair in metrics.items() if key != "cg_residual"
        }
        for case, metrics in result.items()
    }  # the CG residual, a number near zero, is left out: its relative difference means nothing
    for case, metrics in arrays.items():
        worst = {
            key: float(np.nanmax(np.abs(sharded - single) / np.maximum(np.abs(single), 1e-6), initial=0.0))
            for key, (single, sharded) in metrics.items()
        }
        first = {
            key: float(np.nanmax(np.abs(b[0] - a[0]) / np.maximum(np.abs(a[0]), 1e-6)))
            for key, (a, b) in metrics.items()
        }
        key, key0 = max(worst, key=worst.get), max(first, key=first.get)
        print(
            f"\n{case}, 1 vs 4 devices: largest relative difference {first[key0]:.1e} ({key0}) on iteration 1, "
            f"{worst[key]:.1e} ({key}) over 3 iterations"
        )
    for case, metrics in arrays.items():
        for key, (single, sharded) in metrics.items():
            np.testing.assert_allclose(sharded[0], single[0], rtol=1e-4, atol=1e-5, err_msg=f"{case} {key}")
            np.testing.assert_allclose(sharded, single, rtol=1e-2, atol=1e-5, err_msg=f"{case} {key}")


@pytest.mark.skipif(not warp_available(), reason="warp-lang is not installed (pip install 'jaxpg[warp]')")
def test_warp_sampling_under_shard_map():
    """MuJoCo Warp (an XLA custom call that jit's partitioner cannot split) samples and evaluates
    under ``shard_map`` on 2 devices exactly as on one (float32; tolerance 1e-5), resets included."""
    diff = run_devices(WARP_SCRIPT, 2)
    print(f"\nMuJoCo Warp, 1 vs 2 devices: {diff}")
    assert diff["dones_equal"] and diff["any_done"], diff
    for key in ("state_obs", "obs", "rewards", "eval_return"):
        assert diff[key] <= 1e-5, diff


@pytest.mark.parametrize("jit", [False, True])
def test_episodes_from_split_resets_equal_rollout_episodes(jit):
    """``rollout_episodes_from`` states reset from split keys (how a device starts its share of
    the episodes) is ``rollout_episodes`` step for step."""
    env = envs.make("cartpole", max_episode_steps=20)
    config = npg.Config(num_envs=5, horizon=30, value_batch_size=8)
    ts = npg.init(jax.random.PRNGKey(3), env, config)
    act = core.make_act(ts.policy, ts.obs_stats)
    key = jax.random.PRNGKey(7)

    def both(key: jax.Array) -> tuple:
        reset_key, steps_key = jax.random.split(key)
        states = jax.vmap(env.reset)(jax.random.split(reset_key, 5))
        ours = rollout_lib.rollout_episodes_from(env, act, ts.params, states, steps_key, 30)
        return ours, rollout_lib.rollout_episodes(env, act, ts.params, key, 5, 30)

    ours, reference = (jax.jit(both) if jit else both)(key)
    assert float(np.min(np.asarray(reference.valid))) == 0.0  # some episodes ended inside the horizon
    jax.tree.map(np.testing.assert_array_equal, ours, reference)


def test_scaling_benchmark_runs_on_cpu(tmp_path):
    """``benchmarks/scaling.py`` with its docstring's CPU command (tiny sizes, 2 forced devices)."""
    out = tmp_path / "scaling.json"
    env = {**os.environ, "XLA_FLAGS": "--xla_force_host_platform_device_count=2", "JAX_PLATFORMS": "cpu"}
    cmd = [sys.executable, str(ROOT / "benchmarks" / "scaling.py"), "--task", "cartpole"]
    cmd += ["--envs-per-device", "8", "--horizon", "4", "--iterations", "1", "--json", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = json.loads(out.read_text())
    assert [(r["devices"], r["num_envs"]) for r in rows] == [(1, 8), (2, 16)]
    assert all(r["train_steps_per_s"] > 0 and r["raw_steps_per_s"] > 0 for r in rows)
    assert rows[0]["train_efficiency"] == 1.0
    assert "| devices | envs | raw env steps/s" in proc.stdout
