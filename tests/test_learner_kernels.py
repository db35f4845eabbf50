"""``benchmarks/throughput.py learner`` times forms of GAE and of the value fit that it says compute the
same numbers: they do (on tiny shapes, on the CPU), and the larger-minibatch rows take fewer steps."""

from __future__ import annotations

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest
from script_loader import load_script

from jaxpg import value as value_lib
from jaxpg.policies import ValueFunction

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def kernels():
    return load_script("benchmarks/throughput.py").learner


def test_gae_forms_agree(kernels):
    k = jax.random.split(jax.random.PRNGKey(0), 5)
    shape = (16, 5)
    args = (
        jax.random.normal(k[0], shape),
        jax.random.normal(k[1], shape),
        jax.random.normal(k[2], shape),
        jax.random.uniform(k[3], shape) < 0.1,
        jax.random.uniform(k[4], shape) < 0.05,
    )
    forms = kernels.gae_forms(unroll=4)
    assert len(forms) == 3
    outs = [np.asarray(fn(*args)) for fn in forms.values()]
    for out in outs[1:]:
        # The forms sum the same 16 discounted terms (values of size <= ~5) in other orders (the
        # associative scan pairs them up): float32 differences <= 16 ulps of 5, ~1e-5.
        np.testing.assert_allclose(out, outs[0], rtol=1e-5, atol=1e-5)


def test_value_fit_forms_take_the_same_steps(kernels):
    per_epoch = 0  # epochs of full shuffles, as the card's fit at 256 envs
    value_fn = ValueFunction(hidden=(8,))
    obs = jax.random.normal(jax.random.PRNGKey(1), (32, 3))
    targets = jnp.tanh(obs[:, 0])
    params = value_fn.init(jax.random.PRNGKey(2), 3)
    key = jax.random.PRNGKey(3)
    forms = kernels.value_fit_forms(value_fn, 1e-2, epochs=2, batch=4, per_epoch=per_epoch)
    names = list(forms)
    fitted = {name: forms[name](params, obs, targets, key) for name in names}
    reference = fitted[names[0]]
    # The first four forms: the same minibatches in the same order, laid out differently. They are
    # different programs (the compiler may fuse and order their float32 sums otherwise); the fit is a
    # contraction (Adam on a smooth regression), so each step's last-bit differences stay of their
    # size over its 2 x 8 steps: rtol 1e-5 (~100 ulps), atol 1e-6 for parameters near zero. What the
    # test guards against, another minibatch order or number of steps, gives another fit altogether.
    for name in names[1:4]:
        for a, b in zip(jax.tree.leaves(fitted[name]), jax.tree.leaves(reference), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6, err_msg=name)
    # The larger-minibatch rows are fits of their own: the library's fit at 2x and 4x the rows (run
    # op by op here, another program than the benchmark's jitted one: the tolerance above).
    for name, rows in zip(names[4:], (8, 16), strict=True):
        opt = optax.adam(1e-2)
        want, _, _ = value_lib.fit_value(
            value_fn, params, opt.init(params), opt, obs, targets, key, 2, rows, samples_per_epoch=per_epoch
        )
        for a, b in zip(jax.tree.leaves(fitted[name]), jax.tree.leaves(want), strict=True):
            np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-5, atol=1e-6, err_msg=name)


def test_iteration_ablation_variants_and_parallel_gae():
    """``benchmarks/iteration_ablation.py``: its GAE change (``core.gae_advantages`` with
    ``parallel=True``) computes the default's numbers for both value targets, and it times the
    cumulative phases plus the changes asked for."""
    from types import SimpleNamespace

    from jaxpg.algos import core, npg

    ablation = load_script("benchmarks/iteration_ablation.py")
    k = jax.random.split(jax.random.PRNGKey(1), 5)
    shape = (12, 4)
    traj = SimpleNamespace(
        rewards=jax.random.normal(k[0], shape),
        terminated=jax.random.uniform(k[1], shape) < 0.1,
        truncated=jax.random.uniform(k[2], shape) < 0.05,
    )
    values, next_values = jax.random.normal(k[3], shape), jax.random.normal(k[4], shape)
    for target in ("gae", "returns"):
        ts = SimpleNamespace(config=npg.Config(gamma=0.99, gae_lambda=0.9, value_target=target))
        for a, b in zip(
            ablation.PARALLEL_GAE(ts, traj, values, next_values),
            core.gae_advantages(ts, traj, values, next_values),
            strict=True,
        ):
            # sequential and associative scans: the same sums in another order (as above)
            np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-5, atol=1e-5, err_msg=target)
    assert list(ablation.variants([])) == list(ablation.PHASES)
    assert list(ablation.variants(["unroll"]))[4:] == ["raw", f"raw_u{ablation.UNROLL}", f"sample_u{ablation.UNROLL}"]
    assert ablation.variants(["vmb8"])["vmb8"][1] == {"value_minibatches": 8}


def test_iteration_ablation_raw_env_block_does_the_raw_variants_work():
    """``raw_env`` (the ``carry`` change) steps the env batch exactly as the ``raw`` variant does,
    only with another loop carry: the same env states and rewards after 3 iterations.

    The two are different programs, whose float32 physics the compiler may order differently, so
    the integer state (keys, step counters, done flags) is compared exactly and the float state to
    what 24 physics steps make of last-bit differences: a few ulps per step (~1e-7 relative), grown
    by the pendulum's unstable mode, ``exp(5/s * 0.04 s)`` per step, within an episode (random
    actions tip the pole within a few tens of steps, and a reset starts afresh from the same key):
    ~1e-4 at the very worst on states of size <= ~1, so rtol and atol 1e-3. Different actions or
    keys, what the test guards against, move them by 1e-2 to 1. An episode end could flip only if a
    pole angle lay within that difference of the 0.2 rad threshold (measured: bit-identical here).
    """
    import jaxpg.envs as envs
    from jaxpg import train as train_lib
    from jaxpg.algos import npg

    ablation = load_script("benchmarks/iteration_ablation.py")
    assert list(ablation.variants(["carry"]))[4:] == ["raw", "raw_env"]
    ts = npg.init(
        jax.random.PRNGKey(3),
        envs.make("inverted_pendulum", impl="jax"),
        npg.Config(num_envs=4, horizon=8, eval_envs=0, value_batch_size=8),
    )
    by_update, metrics = jax.jit(lambda t: train_lib.scan_updates(ablation.rollout_only(policy=False), t, 3))(ts)
    by_block, block_metrics = jax.jit(ablation.raw_env_block(3))(ts)
    for a, b in zip(
        jax.tree.leaves((by_update.env_state, by_update.key)),
        jax.tree.leaves((by_block.env_state, by_block.key)),
        strict=True,
    ):
        a, b = np.asarray(a), np.asarray(b)
        if np.issubdtype(a.dtype, np.floating):
            np.testing.assert_allclose(a, b, rtol=1e-3, atol=1e-3)
        else:
            np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(np.asarray(metrics["reward"]), np.asarray(block_metrics["reward"]), rtol=1e-3)
