"""The env batch split over several devices trains like one device.

The device count is fixed when JAX starts, so the multi-device checks run in subprocesses with
``XLA_FLAGS=--xla_force_host_platform_device_count=4`` (or 2). NPG on ``cartpole``, once on one
device and once with the state on a 4-device mesh (``jaxpg.algos.core.shard_state``) and ``update``
traced on it (``jaxpg.mesh.on_mesh``): sampling and evaluation then run under
``jax.shard_map``, each device stepping its own envs, and the learning side under jit's
partitioner. Both must give the same metrics up to float reduction order.

Why equal: the sampled actions are those of the unsplit batch bit for bit (each device draws the
noise of the whole batch and keeps its rows, ``core.sampling.sample_rows``; resets use the same split
keys), and every reduction (advantage normalisation, gradients, Fisher-vector products, value fit,
metrics) is global, so only the order of float32 summation differs.

What that allows to compare (the sharded program is another program, whose float32 sums may be
ordered otherwise on another CPU, vector width or thread count):
- Integer state exactly: each run's RNG keys and iteration counter after its 3 iterations, and the
  counts among the metrics of the first iteration.
- The first iteration starts both programs from the same state. Its rollout, advantages, gradient
  and value fit are float32 sums of at most a few thousand terms (relative difference <= ~1e-5),
  and its step solves ``(F + damping I) x = g`` by conjugate gradient, which amplifies a relative
  perturbation by up to the condition number ``1 + lambda_max(F) / damping``. Hence the configs'
  ``cg_damping=1.0``: ``lambda_max(F)`` of this cartpole policy, computed densely, is 3.6-12.7 over
  the first three iterations of both cases (the Fisher matrix has rank <= 9 of 4610), so the
  condition number is <= ~14 and the step's diagnostics differ by <= ~2e-4: every metric is
  compared with rtol 1e-3 (atol 1e-5 for those near zero). At ``cg_damping=1e-2`` the condition
  number would be ~1.3e3 and the tolerance would have to be a few 1e-2. The CG residual, itself
  round-off, is left out.
- From the second iteration on the programs step from parameters that may differ in the last bits,
  and an episode can end a step earlier or later: no float tolerance follows from the computation.
  What a wrong split (envs stepped twice or not at all, a device's rows lost from a reduction,
  states shuffled between devices) would break is that the sharded run's metrics lie far closer to
  its own seed's unsharded run than to another seed's (``SEED_DISCRIMINATING``, asserted to differ
  by more than 5 % between the seeds): the sharded run must be within a tenth of the seed gap, every
  iteration.
Measured (printed with ``-s``; AMD EPYC, JAX 0.10): at most 6e-7 relative on the first iteration and
2e-6 on the next two.
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
    from jaxpg import mesh as mesh_lib
    from jaxpg import train
    from jaxpg.algos import npg
    from jaxpg.algos.core import shard_state

    assert len(jax.devices()) == 4, jax.devices()
    mesh = mesh_lib.env_mesh()
    env = envs.make("cartpole")
    cases = {
        # eval_envs 6 over 4 devices: padded to 8, the 2 extra episodes left out of the means
        "continuing_seeds": (npg.Config(num_envs=16, horizon=32, eval_envs=6, eval_horizon=64, value_batch_size=64,
                                        cg_damping=1.0), True),
        "episodic": (npg.Config(num_envs=8, horizon=48, sampling="episodic", eval_envs=4, eval_horizon=48,
                                value_batch_size=64, cg_damping=1.0), False),
    }
    out = {}
    for name, (config, seeds) in cases.items():
        def init(seed=0):
            if seeds:
                return train.init_seeds(npg.init, [seed, seed + 1], env, config)
            return npg.init(jax.random.PRNGKey(seed), env, config)

        step = jax.vmap(npg.update) if seeds else npg.update
        single_block = jax.jit(lambda ts: train.scan_updates(step, ts, 3))
        single_state, single = single_block(init())
        # another seed's run, the scale of what a mix-up would change (the seeds case holds it already)
        other = single if seeds else single_block(init(1))[1]
        sharded_step = mesh_lib.on_mesh(step, mesh)
        block = jax.jit(lambda ts: train.scan_updates(sharded_step, ts, 3))
        state = shard_state(init(), vmap_seeds=seeds, mesh=mesh)
        assert len(state.env_state.obs.sharding.device_set) == 4
        assert "shard_map" in str(jax.make_jaxpr(sharded_step)(state)), "sampling is not under shard_map"
        state, sharded = block(state)
        assert len(state.env_state.obs.sharding.device_set) == 4
        out[name] = {
            "metrics": {k: [np.asarray(single[k]).tolist(), np.asarray(sharded[k]).tolist()] for k in single},
            "other_seed": {k: np.asarray(other[k])[..., ::-1].tolist() if seeds else np.asarray(other[k]).tolist()
                           for k in other},
            "integer_state": [[np.asarray(s.key).tolist(), np.asarray(s.iteration).tolist()]
                              for s in (single_state, state)],
        }

    # a batch that does not split over the devices is refused with one line
    bad = npg.init(jax.random.PRNGKey(0), env, npg.Config(num_envs=6, horizon=8, value_batch_size=8, eval_envs=0))
    try:
        jax.jit(mesh_lib.on_mesh(npg.update, mesh))(bad)
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
    from jaxpg import mesh as mesh_lib
    from jaxpg.algos import core, npg
    from jaxpg.algos.core import shard_state

    warp.config.quiet = True
    assert len(jax.devices()) == 2, jax.devices()
    # each device steps 2 of the 4 envs, with its own contact buffer (sized for the unsplit reference)
    env = envs.make("inverted_pendulum", impl="warp", max_batch=4, max_episode_steps=6)
    config = npg.Config(num_envs=4, horizon=8, eval_envs=2, eval_horizon=8, value_batch_size=8)
    ts = npg.init(jax.random.PRNGKey(0), env, config)
    mesh = mesh_lib.env_mesh()

    def run(ts):
        ts, traj, _ = core.phase_sample(ts)
        return ts.env_state.obs, traj.obs, traj.rewards, traj.dones, core.evaluate(ts, ts.key)

    single = jax.jit(run)(ts)
    sharded = jax.jit(mesh_lib.on_mesh(run, mesh))(shard_state(ts, vmap_seeds=False, mesh=mesh))
    assert len(sharded[0].sharding.device_set) == 2
    assert "shard_map" in str(jax.make_jaxpr(mesh_lib.on_mesh(run, mesh))(ts))
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
        # kept: other XLA flags (e.g. ``--xla_cpu_max_isa``) of the caller
        "XLA_FLAGS": f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count={devices}",
        "JAX_PLATFORMS": "cpu",
    }
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=900)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stderr[-3000:]
    return json.loads(lines[0][len("RESULT ") :])


# Metrics of an iteration that discriminate between seeds and do not pass through the
# conjugate-gradient solve.
SEED_DISCRIMINATING = ("value_loss", "grad_norm", "return_stochastic")


def relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``|a - b| / |b|`` elementwise, with ``|b|`` floored at 1e-6 for numbers near zero."""
    return np.abs(a - b) / np.maximum(np.abs(b), 1e-6)


def test_sharded_npg_matches_single_device():
    """NPG on cartpole, 1 device vs the env batch split over 4 (continuing sampling with two
    vmapped seeds; episodic sampling), and the one-line error for an indivisible batch; what is
    compared, and with which tolerance, the module docstring says."""
    result = run_devices(CARTPOLE_SCRIPT, 4)
    assert "num_envs 6 is not divisible by the 4 devices" in result.pop("indivisible")
    mismatches = []
    for case, data in result.items():
        single_state, sharded_state = data["integer_state"]
        assert single_state == sharded_state, case  # RNG keys and iteration counters, exactly
        metrics = {key: tuple(np.array(x, dtype=float) for x in pair) for key, pair in data["metrics"].items()}
        other = {key: np.array(x, dtype=float) for key, x in data["other_seed"].items()}
        first = {key: float(np.max(relative(b[0], a[0]))) for key, (a, b) in metrics.items() if key != "cg_residual"}
        later = {key: float(np.max(relative(metrics[key][1][1:], metrics[key][0][1:]))) for key in SEED_DISCRIMINATING}
        key0, key1 = max(first, key=first.get), max(later, key=later.get)
        print(
            f"\n{case}, 1 vs 4 devices: largest relative difference {first[key0]:.1e} ({key0}) on iteration 1, "
            f"{later[key1]:.1e} ({key1}) on iterations 2-3"
        )
        for key, (single, sharded) in metrics.items():
            if key != "cg_residual":  # round-off itself: its relative difference means nothing
                np.testing.assert_allclose(sharded[0], single[0], rtol=1e-3, atol=1e-5, err_msg=f"{case} {key}")
        for key in SEED_DISCRIMINATING:
            single, sharded = metrics[key]
            own_gap, seed_gap = np.abs(sharded - single), np.abs(other[key] - single)
            assert np.all(seed_gap > 0.05 * np.abs(single)), (case, key, single, other[key])  # the seeds do differ
            if not np.all(own_gap < 0.1 * seed_gap):
                mismatches.append((case, key, sharded.tolist(), single.tolist(), other[key].tolist()))
    assert not mismatches, mismatches


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
    """``benchmarks/throughput.py scaling`` with its docstring's CPU command (tiny sizes, 2 forced devices)."""
    out = tmp_path / "scaling.json"
    env = {
        **os.environ,
        "XLA_FLAGS": f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count=2",
        "JAX_PLATFORMS": "cpu",
    }
    cmd = [sys.executable, str(ROOT / "benchmarks" / "throughput.py"), "scaling", "--task", "cartpole"]
    cmd += ["--envs-per-device", "8", "--horizon", "4", "--iterations", "1", "--json", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = json.loads(out.read_text())["rows"]
    assert [(r["devices"], r["num_envs"]) for r in rows] == [(1, 8), (2, 16)]
    assert all(r["train_steps_per_s"] > 0 and r["raw_steps_per_s"] > 0 for r in rows)
    assert rows[0]["train_efficiency"] == 1.0
    assert "| devices | envs | raw env steps/s" in proc.stdout
