"""``npg.update_with_step_size``: NPG's update with a traced step size, so that one program can
``vmap`` over step sizes (notebook 05, section 4). ``Config`` is a static field of ``TrainState``,
so ``config.step_size`` itself cannot be batched.

With ``step_size = config.step_size`` it is ``npg.update`` bit for bit; vmapped over several step
sizes it gives each step size's own run of ``npg.update`` (with that ``config.step_size``).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxpg.envs as envs
from jaxpg import train as train_lib
from jaxpg.algos import npg

ITERATIONS = 2
# Damping 0.1 keeps the Fisher system well conditioned, so that the float rounding of a vmapped
# program (batched reductions) is not amplified by conjugate gradient beyond the tolerance below.
CONFIG = npg.Config(num_envs=8, horizon=24, policy_hidden=(8,), value_hidden=(8,), value_batch_size=64, cg_damping=0.1)
# 3.0 exceeds max_update_kl (1.0): its bound is capped and the backtracking halves its step.
STEP_SIZES = (0.01, 0.1, 3.0)


@pytest.fixture(scope="module")
def env():
    return envs.make("cartpole")


@pytest.fixture(scope="module")
def initial(env):
    return npg.init(jax.random.PRNGKey(11), env, CONFIG)


def scan_with_step_size(ts, step_size):
    return jax.lax.scan(lambda s, _: npg.update_with_step_size(s, step_size), ts, None, length=ITERATIONS)


def leaves(tree):
    return [np.asarray(x) for x in jax.tree.leaves(tree)]


def test_config_step_size_is_npg_update_bit_for_bit(initial):
    ref_state, ref_metrics = jax.jit(lambda s: train_lib.scan_updates(npg.update, s, ITERATIONS))(initial)
    # Traced step size: the same compiled program serves every value.
    state, metrics = jax.jit(scan_with_step_size)(initial, jnp.float32(CONFIG.step_size))
    assert metrics.keys() == ref_metrics.keys()
    for a, b in zip(leaves((state, metrics)), leaves((ref_state, ref_metrics)), strict=True):
        np.testing.assert_array_equal(a, b)
    assert float(np.min(ref_metrics["kl"])) > 0  # the policy did move


def test_vmap_over_step_sizes_matches_single_runs(initial, env):
    sizes = jnp.array(STEP_SIZES, jnp.float32)
    states, metrics = jax.jit(jax.vmap(scan_with_step_size, in_axes=(None, 0)))(initial, sizes)
    fractions = []
    for i, size in enumerate(STEP_SIZES):
        ts = npg.init(jax.random.PRNGKey(11), env, dataclasses.replace(CONFIG, step_size=size))
        ref_state, ref_metrics = jax.jit(lambda s: train_lib.scan_updates(npg.update, s, ITERATIONS))(ts)
        got = jax.tree.map(lambda x, i=i: x[i], (states.params, states.value_params, metrics))
        for a, b in zip(leaves(got), leaves((ref_state.params, ref_state.value_params, ref_metrics)), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)
        fractions.append(float(np.min(ref_metrics["step_fraction"])))
    # The sweep exercises the traced KL bound: the largest step size backtracks, the smallest does not.
    assert fractions[0] == 1.0 and fractions[-1] < 1.0, fractions
    np.testing.assert_array_equal(np.asarray(metrics["kl"] > 0), True)


def test_kl_bound_follows_step_size():
    config = dataclasses.replace(CONFIG, max_update_kl=0.2)
    assert npg.kl_bound(config) == CONFIG.step_size
    assert float(npg.kl_bound(config, jnp.float32(0.1))) == pytest.approx(0.1)
    assert float(npg.kl_bound(config, jnp.float32(0.5))) == pytest.approx(0.2)
    off = dataclasses.replace(CONFIG, max_update_kl=0.0)
    assert float(npg.kl_bound(off, jnp.float32(3.0))) == 3.0
