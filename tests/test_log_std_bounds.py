"""The bounds on a Gaussian policy's log-std (``core.log_std_bounds``): the falling ceiling
(``anneal_log_std_iterations``, ``log_std_final``) against the linear formula in NumPy, the floor
(``log_std_min``), what an iteration applies (against the same iteration without it, which is the
same program up to the clip), and the settings refused."""

from __future__ import annotations

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
    assert clipped.params["mean"] is ts.params["mean"]  # nothing but the log-std


def test_every_iteration_clips_the_learned_log_std_to_its_bounds(pendulum):
    """A2C (one optimizer step an iteration, Adam at lr 1e-3) with the ceiling falling from 0.5 to
    -1 over 4 iterations and a floor at -0.7. Adam moves a parameter by at most
    ``lr (1 - beta1) / sqrt(1 - beta2)`` (about 3.2e-3) a step (Kingma and Ba 2015, section 2.1), far
    less than the ceiling falls an iteration (0.375), so each iteration's update leaves the log-std
    above the new ceiling and the clip sets it exactly: 0.125, -0.25, -0.625, then the floor -0.7,
    which wins over the ceiling's -1 from iteration 4 on. One compiled program."""
    config = a2c.Config(num_envs=4, horizon=8, eval_envs=0, optimizer="adam", lr=1e-3, log_std_min=-0.7, **SCHEDULE)
    config.validate(pendulum)
    ts = a2c.init(jax.random.key(1), pendulum, config)
    update = jax.jit(a2c.update)
    seen = []
    for _ in range(6):
        ts, _ = update(ts)
        seen.append(np.asarray(ts.params["log_std"]))
    expected = np.array([0.125, -0.25, -0.625, -0.7, -0.7, -0.7], np.float32)[:, None]
    np.testing.assert_array_equal(np.stack(seen), np.broadcast_to(expected, (6, pendulum.action_size)))


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
