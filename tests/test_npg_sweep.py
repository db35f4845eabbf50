"""``npg.update_with_kl_delta``: NPG's update with a traced ``kl_delta`` (the normalised step's
delta), so that one program can ``vmap`` over its values (notebook 05, section 4). ``Config`` is a
static field of ``TrainState``, so ``config.kl_delta`` itself cannot be batched.

With ``kl_delta = config.kl_delta`` it is ``npg.update`` bit for bit; vmapped over several values
it gives each value's own run of ``npg.update`` (with that ``config.kl_delta``).
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
KL_DELTAS = (0.01, 0.1, 3.0)


@pytest.fixture(scope="module")
def env():
    return envs.make("cartpole")


@pytest.fixture(scope="module")
def initial(env):
    return npg.init(jax.random.PRNGKey(11), env, CONFIG)


def scan_with_kl_delta(ts, kl_delta):
    return jax.lax.scan(lambda s, _: npg.update_with_kl_delta(s, kl_delta), ts, None, length=ITERATIONS)


def leaves(tree):
    return [np.asarray(x) for x in jax.tree.leaves(tree)]


def test_config_kl_delta_is_npg_update_bit_for_bit(initial):
    ref_state, ref_metrics = jax.jit(lambda s: train_lib.scan_updates(npg.update, s, ITERATIONS))(initial)
    # Traced kl_delta: the same compiled program serves every value.
    state, metrics = jax.jit(scan_with_kl_delta)(initial, jnp.float32(CONFIG.kl_delta))
    assert metrics.keys() == ref_metrics.keys()
    for a, b in zip(leaves((state, metrics)), leaves((ref_state, ref_metrics)), strict=True):
        np.testing.assert_array_equal(a, b)
    assert float(np.min(ref_metrics["kl"])) > 0  # the policy did move


def test_vmap_over_kl_deltas_matches_single_runs(initial, env):
    deltas = jnp.array(KL_DELTAS, jnp.float32)
    states, metrics = jax.jit(jax.vmap(scan_with_kl_delta, in_axes=(None, 0)))(initial, deltas)
    fractions = []
    for i, delta in enumerate(KL_DELTAS):
        ts = npg.init(jax.random.PRNGKey(11), env, dataclasses.replace(CONFIG, kl_delta=delta))
        ref_state, ref_metrics = jax.jit(lambda s: train_lib.scan_updates(npg.update, s, ITERATIONS))(ts)
        got = jax.tree.map(lambda x, i=i: x[i], (states.params, states.value_params, metrics))
        for a, b in zip(leaves(got), leaves((ref_state.params, ref_state.value_params, ref_metrics)), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)
        fractions.append(float(np.min(ref_metrics["step_fraction"])))
    # The sweep exercises the traced KL bound: the largest kl_delta backtracks, the smallest does not.
    assert fractions[0] == 1.0 and fractions[-1] < 1.0, fractions
    np.testing.assert_array_equal(np.asarray(metrics["kl"] > 0), True)


def test_kl_bound_follows_kl_delta():
    config = dataclasses.replace(CONFIG, max_update_kl=0.2)
    assert npg.kl_bound(config) == CONFIG.kl_delta
    assert float(npg.kl_bound(config, jnp.float32(0.1))) == pytest.approx(0.1)
    assert float(npg.kl_bound(config, jnp.float32(0.5))) == pytest.approx(0.2)
    off = dataclasses.replace(CONFIG, max_update_kl=0.0)
    assert float(npg.kl_bound(off, jnp.float32(3.0))) == 3.0
