"""``npg.update_with_kl_delta``: NPG's update with a traced ``kl_delta`` (the normalised step's
delta), so that one program can ``vmap`` over its values (notebook 05, section 4). ``Config`` is a
static field of ``TrainState``, so ``config.kl_delta`` itself cannot be batched.

With ``kl_delta = config.kl_delta`` it is ``npg.update``; vmapped over several values it gives each
value's own run of ``npg.update`` (with that ``config.kl_delta``). Each comparison is between two
different programs (a traced delta against a constant one, a vmapped program against an unvmapped
one), whose float32 sums the compiler may order differently on another CPU, vector width or JAX
version, so they are compared as far as float32 allows:
- Integer state exactly: the RNG keys and iteration counters after the two iterations.
- The first iteration starts from the same state: its rollout, advantages, gradient and value fit
  are float32 sums of at most a few thousand terms (relative difference <= ~1e-5), and conjugate
  gradient amplifies that by up to the condition number ``1 + lambda_max(F) / cg_damping`` of its
  solve. ``CONFIG``'s damping 0.1 bounds that by ~16 (``lambda_max(F)`` of this small policy is
  1.5 at the first iteration, whatever the delta, by power iteration), so the step's diagnostics
  differ by <= ~2e-4 and every metric of the first iteration is compared with rtol 1e-3 (atol 1e-6
  for numbers near zero; the CG residual, itself round-off, is left out).
- The second iteration steps from parameters that may differ in the last bits, and an episode can
  end a step earlier or later: no float tolerance follows from the computation. What a mix-up
  would break is that each run's final parameters lie far closer to its own reference than the
  references lie to each other (another ``kl_delta``), or than the two iterations moved them.
Measured (``-s``; AMD EPYC, JAX 0.10): traced and constant delta bit-identical there; the vmapped
sweep 5e-6 relative on the first iteration, final parameters 3e-6 of the gap between deltas.
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
# Damping 0.1: a well-conditioned Fisher solve (module docstring).
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


def distance(a, b) -> float:
    """Euclidean distance between two pytrees of the same structure."""
    return float(np.sqrt(sum(np.sum(np.square(x - y)) for x, y in zip(leaves(a), leaves(b), strict=True))))


def assert_first_iteration_close(metrics, reference) -> float:
    """Every metric of the first iteration (row 0) within float32's allowance (module docstring);
    returns the largest relative difference."""
    assert metrics.keys() == reference.keys()
    worst = 0.0
    for key, want in reference.items():
        if key == "cg_residual":
            continue
        got, want = np.asarray(metrics[key][0]), np.asarray(want[0])
        np.testing.assert_allclose(got, want, rtol=1e-3, atol=1e-6, err_msg=key)
        worst = max(worst, float(np.abs(got - want) / max(abs(float(want)), 1e-6)))
    return worst


def test_config_kl_delta_is_npg_update(initial):
    ref_state, ref_metrics = jax.jit(lambda s: train_lib.scan_updates(npg.update, s, ITERATIONS))(initial)
    # Traced kl_delta: the same compiled program serves every value.
    state, metrics = jax.jit(scan_with_kl_delta)(initial, jnp.float32(CONFIG.kl_delta))
    np.testing.assert_array_equal(np.asarray(state.key), np.asarray(ref_state.key))
    assert int(state.iteration) == int(ref_state.iteration) == ITERATIONS
    worst = assert_first_iteration_close(metrics, ref_metrics)
    gap, moved = distance(state.params, ref_state.params), distance(ref_state.params, initial.params)
    print(
        f"\ntraced vs constant kl_delta: first iteration {worst:.1e} relative; "
        f"parameters {gap / moved:.1e} of their move"
    )
    assert gap < 0.1 * moved, (gap, moved)
    assert float(np.min(ref_metrics["kl"])) > 0  # the policy did move


def test_vmap_over_kl_deltas_matches_single_runs(initial, env):
    deltas = jnp.array(KL_DELTAS, jnp.float32)
    states, metrics = jax.jit(jax.vmap(scan_with_kl_delta, in_axes=(None, 0)))(initial, deltas)
    fractions, references = [], []
    for delta in KL_DELTAS:
        ts = npg.init(jax.random.PRNGKey(11), env, dataclasses.replace(CONFIG, kl_delta=delta))
        references.append(jax.jit(lambda s: train_lib.scan_updates(npg.update, s, ITERATIONS))(ts))
    worst, ratio = 0.0, 0.0
    for i, (ref_state, ref_metrics) in enumerate(references):
        np.testing.assert_array_equal(np.asarray(states.key[i]), np.asarray(ref_state.key))
        assert int(states.iteration[i]) == int(ref_state.iteration) == ITERATIONS
        worst = max(worst, assert_first_iteration_close(jax.tree.map(lambda x, i=i: x[i], metrics), ref_metrics))
        params = jax.tree.map(lambda x, i=i: x[i], states.params)
        gap = distance(params, ref_state.params)
        others = min(distance(other.params, ref_state.params) for j, (other, _) in enumerate(references) if j != i)
        ratio = max(ratio, gap / others)
        assert gap < 0.1 * others, (KL_DELTAS[i], gap, others)
        fractions.append(float(np.min(ref_metrics["step_fraction"])))
    print(f"\nvmapped kl_deltas: first iteration {worst:.1e} relative; parameters {ratio:.1e} of the deltas' gap")
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


def test_annealed_kl_delta_steps_with_the_linear_decay_then_stops(initial):
    """``anneal_kl_iterations = N``: the iteration that starts with ``t`` iterations done steps with
    ``kl_delta * (1 - t / N)`` (``update_with_kl_delta`` at that value, compared as far as float32
    allows, as above), and from iteration ``N`` on the policy does not move."""
    annealing = 4
    config = dataclasses.replace(CONFIG, kl_delta=0.1, anneal_kl_iterations=annealing)
    schedule = [float(npg.kl_delta_at(config, jnp.int32(t))) for t in range(6)]
    np.testing.assert_allclose(schedule, [0.1, 0.075, 0.05, 0.025, 0.0, 0.0], rtol=1e-6, atol=0)
    assert npg.kl_delta_at(CONFIG, jnp.int32(3)) == CONFIG.kl_delta  # no annealing: constant
    with pytest.raises(ValueError, match="anneal_kl_iterations"):
        dataclasses.replace(CONFIG, anneal_kl_iterations=-1).validate(envs.make("cartpole"))

    annealed_update = jax.jit(npg.update)
    for done, delta in ((2, 0.05), (annealing, 0.0)):
        ts = initial.replace(config=config, iteration=jnp.int32(done))
        new, metrics = annealed_update(ts)
        ref_state, ref_metrics = jax.jit(npg.update_with_kl_delta)(ts, jnp.float32(delta))
        batched = lambda tree: jax.tree.map(lambda x: np.asarray(x)[None], tree)  # noqa: E731
        assert_first_iteration_close(batched(metrics), batched(ref_metrics))
        if delta == 0.0:
            assert float(metrics["kl"]) == 0.0 and float(metrics["step_length"]) == 0.0
            assert distance(new.params, ts.params) == 0.0
        else:
            assert float(metrics["kl"]) > 0.0
            assert distance(new.params, ref_state.params) < 0.1 * distance(ref_state.params, ts.params)
