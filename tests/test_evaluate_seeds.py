"""The mean-policy evaluation of several seeds trained in one program: ``core.evaluate_seeds_together``
(every seed's episodes as one flat batch in one loop, what MuJoCo Warp runs) against ``jax.vmap``
of the single-seed ``core.evaluate``, and ``train.evaluate_seeds`` choosing it for a Warp env.

On inverted_pendulum with MJX's JAX implementation, whose steps do not depend on the batch they
run in: each seed's episodes (reset keys, deterministic actions, time limit) are the same either
way, so the lengths agree exactly and the returns (sums of per-step rewards) to float32 rounding
of sums over up to 50 steps. The policies' weights are scaled up so that episodes end at different
steps and some mean actions lie outside the bounds."""

from __future__ import annotations

import dataclasses

import jax
import numpy as np
import pytest

from jaxpg import envs, train
from jaxpg.algos import core, npg

CONFIG = npg.Config(
    num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), value_batch_size=8, eval_envs=5, eval_horizon=50
)
SEEDS = [0, 1, 2]


class ReportsWarp(envs.Wrapper):
    """The env as it is, reporting ``impl == "warp"``: ``train.evaluate_seeds`` then takes its Warp path."""

    impl = "warp"


@pytest.fixture(scope="module")
def seeds_state():
    env = envs.make("inverted_pendulum", impl="jax")
    ts = train.init_seeds(npg.init, SEEDS, env, CONFIG)
    return ts.replace(params=jax.tree.map(lambda x: x * 3.0, ts.params))


def per_seed(evaluate, ts, keys):
    return jax.vmap(evaluate)(ts, keys)


def test_together_gives_each_seeds_own_episodes(seeds_state):
    """With the clipped mean as the mean policy's action (the next test plays the mode)."""
    ts = seeds_state.replace(config=dataclasses.replace(CONFIG, eval_action="clipped_mean"))
    keys = jax.random.split(jax.random.PRNGKey(3), len(SEEDS))
    together = jax.jit(core.evaluate_seeds_together)(ts, keys)
    alone = jax.jit(lambda ts, keys: per_seed(core.evaluate, ts, keys))(ts, keys)
    np.testing.assert_array_equal(together["episode_length"], alone["episode_length"])
    np.testing.assert_allclose(together["episode_return"], alone["episode_return"], rtol=1e-6)
    np.testing.assert_allclose(together["episode_task_score"], alone["episode_task_score"], rtol=1e-6)
    np.testing.assert_array_equal(together["episodes"], [5.0, 5.0, 5.0])
    lengths = np.asarray(alone["episode_length"])
    assert lengths.min() < 50 and len(set(lengths.tolist())) > 1  # the seeds differ, and some fall


def test_evaluate_seeds_runs_the_seeds_together_on_warp(seeds_state):
    """``train.evaluate_seeds`` with the default evaluation on a Warp env: the metrics of
    ``jax.vmap(train.evaluate_state)``; a custom evaluation goes seed by seed, with the same result."""
    expected = jax.jit(jax.vmap(train.evaluate_state))(seeds_state)
    on_warp = seeds_state.replace(env=ReportsWarp(seeds_state.env))
    together = jax.jit(lambda ts: train.evaluate_seeds(train.evaluate_state, ts))(on_warp)
    one_by_one = jax.jit(lambda ts: train.evaluate_seeds(lambda s: train.evaluate_state(s), ts))(on_warp)
    for name in train.EVAL_METRICS:
        np.testing.assert_allclose(together[name], expected[name], rtol=1e-6, err_msg=name)
        np.testing.assert_allclose(one_by_one[name], expected[name], rtol=1e-6, err_msg=name)
