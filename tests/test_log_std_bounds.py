"""The bounds on a Gaussian policy's log-std (``core.log_std_bounds``): the falling ceiling
(``anneal_log_std_iterations``, ``log_std_final``) against the linear formula in NumPy, the floor
(``log_std_min``), what an iteration applies (against the same iteration without it, which is the
same program up to the clip), and the settings refused."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxpg.envs as envs
from jaxpg.algos import a2c, core, npg

SCHEDULE = dict(log_std_init=0.5, log_std_final=-1.0, anneal_log_std_iterations=4)


@pytest.mark.parametrize("done", [0, 1, 2, 3, 4, 5, 40])
def test_the_ceiling_falls_linearly_from_the_initial_log_std_to_the_final_then_stays(done):
    config = npg.Config(**SCHEDULE)
    expected = 0.5 + (-1.0 - 0.5) * min(done / 4, 1.0)
    np.testing.assert_allclose(float(core.log_std_ceiling(config, jnp.asarray(done))), expected, rtol=0, atol=1e-6)


@pytest.fixture(scope="module")
def pendulum():
    return envs.make("inverted_pendulum")


def test_without_bounds_the_state_is_left_as_it_is(pendulum):
    config = a2c.Config(num_envs=2, horizon=4, eval_envs=0, log_std_init=0.5)
    ts = a2c.init(jax.random.key(0), pendulum, config)
    assert core.clip_log_std(ts, jnp.asarray(3)) is ts


@pytest.mark.parametrize(
    "bounds, done, expected",
    [
        (dict(log_std_min=0.25), 7, [0.25, 0.3, 2.0]),  # the floor alone: no ceiling
        (dict(log_std_min=-0.5, **SCHEDULE), 2, [-0.5, -0.25, -0.25]),  # ceiling 0.5 - 1.5 * 2/4
        (dict(log_std_min=-0.5, **SCHEDULE), 4, [-0.5, -0.5, -0.5]),  # the ceiling ends at -1: the floor wins
        (dict(log_std_min=0.5, log_std_init=0.5, log_std_final=0.5, anneal_log_std_iterations=1), 9, [0.5] * 3),
    ],
)
def test_the_log_std_is_clipped_to_the_floor_and_the_ceiling(pendulum, bounds, done, expected):
    """``clip_log_std`` on a state whose log-std is set by hand to ``[-3, 0.3, 2]``: the floor
    raises what lies below it, the ceiling (when annealing) lowers what lies above it; a floor at
    the initial log-std with a constant ceiling there holds it fixed."""
    config = npg.Config(**{"log_std_init": 0.5, **bounds})
    ts = npg.init(jax.random.key(0), pendulum, config)
    ts = ts.replace(params={**ts.params, "log_std": jnp.array([-3.0, 0.3, 2.0])})
    clipped = core.clip_log_std(ts, jnp.asarray(done))
    np.testing.assert_allclose(np.asarray(clipped.params["log_std"]), expected, rtol=0, atol=1e-6)


def test_an_iteration_caps_the_learned_log_std_and_nothing_else(pendulum):
    """A2C (one cheap program per config) from the same state, one iteration with the schedule
    and one without: the first iteration's learned log-std is the same number either way (the cap
    comes after the update), so the capped run's is ``min(uncapped, ceiling(1))``, and every other
    parameter is the uncapped run's. The two programs differ only by that elementwise minimum, but
    the compiler may fuse them differently, so float32 round-off (1e-6 relative) is allowed. Over
    more iterations it never exceeds the ceiling and reaches the final log-std once the ceiling binds."""
    base = a2c.Config(num_envs=4, horizon=8, eval_envs=0, log_std_init=0.5, lr=1e-3)
    annealed = dataclasses.replace(base, **SCHEDULE)
    annealed.validate(pendulum)
    free = a2c.init(jax.random.key(1), pendulum, base)
    capped = free.replace(config=annealed)
    free_next, _ = jax.jit(a2c.update)(free)
    update = jax.jit(a2c.update)
    capped_next, _ = update(capped)
    ceiling = 0.5 - 1.5 / 4
    assert float(free_next.params["log_std"][0]) > ceiling  # a small step from 0.5: the cap binds
    np.testing.assert_allclose(
        capped_next.params["log_std"],
        np.minimum(np.asarray(free_next.params["log_std"]), np.float32(ceiling)),
        rtol=1e-6,
        atol=1e-7,
    )
    means = zip(jax.tree.leaves(capped_next.params["mean"]), jax.tree.leaves(free_next.params["mean"]), strict=True)
    for a, b in means:
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-7)
    ts = capped_next
    for done in range(2, 7):
        ts, _ = update(ts)
        assert np.all(np.asarray(ts.params["log_std"]) <= float(core.log_std_ceiling(annealed, jnp.asarray(done))))
    np.testing.assert_allclose(np.asarray(ts.params["log_std"]), -1.0, atol=0.05)


@pytest.mark.parametrize(
    "task, overrides, message",
    [
        ("inverted_pendulum", dict(anneal_log_std_iterations=-1), "anneal_log_std_iterations must be >= 0"),
        ("inverted_pendulum", dict(log_std_init=0.0, log_std_final=0.5, anneal_log_std_iterations=10), "only falls"),
        ("inverted_pendulum", dict(policy="state_std_gaussian", anneal_log_std_iterations=10), "gaussian policy"),
        ("cartpole", dict(anneal_log_std_iterations=10), "gaussian policy"),
        ("cartpole", dict(log_std_min=-1.0), "gaussian policy"),
        ("inverted_pendulum", dict(log_std_init=0.0, log_std_min=0.5), "log_std_min .* must be <= log_std_init"),
    ],
)
def test_settings_without_a_learned_global_log_std_are_refused(task, overrides, message):
    with pytest.raises(ValueError, match=message):
        npg.Config(**overrides).validate(envs.make(task))
