"""PPO and A2C: the non-finite guard, validation, multi-seed training. Their learning tests (A2C on
``cartpole``, PPO on ``inverted_pendulum``, two seeds each) are in ``tests/test_learning.py``."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from jaxpg import envs
from jaxpg import train as train_lib
from jaxpg.algos import a2c, actor_critic, core, ppo

# Tiny settings for the checks below: few samples, short evaluation, small compiled programs.
TINY = dict(num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), eval_envs=2, eval_horizon=16)
TINY_CONFIGS = {
    "ppo": ppo.Config(**TINY, num_minibatches=2, num_epochs=2, value_clip_eps=0.2, normalize_observations=True),
    "a2c": a2c.Config(**TINY, optimizer="rmsprop"),
}
ALGOS = {"ppo": ppo, "a2c": a2c}


@pytest.fixture(scope="module")
def cartpole():
    return envs.make("cartpole")


@pytest.mark.parametrize("name", ["ppo", "a2c"])
def test_update_rejects_non_finite_step(name, cartpole):
    """NaN observation statistics poison the batch, hence the loss and every parameter; the update
    must be rolled back and counted, while sampling still advances. Same compiled ``update`` as a
    healthy state, which is accepted and moves the parameters."""
    algo, config = ALGOS[name], TINY_CONFIGS[name]
    update = jax.jit(algo.update)
    ts = algo.init(jax.random.PRNGKey(0), cartpole, config)
    stats = ts.obs_stats.replace(mean=jnp.full_like(ts.obs_stats.mean, jnp.nan), count=jnp.ones(()))
    poisoned = ts.replace(obs_stats=stats)
    new, metrics = update(poisoned)
    assert float(metrics["update_rejected"]) == 1.0
    assert float(metrics["consecutive_failures"]) == 1.0
    assert int(new.failures) == 1 and int(new.iteration) == 1
    for old_leaf, new_leaf in zip(
        jax.tree.leaves((ts.params, ts.value_params, ts.opt_state)),
        jax.tree.leaves((new.params, new.value_params, new.opt_state)),
        strict=True,
    ):
        np.testing.assert_array_equal(np.asarray(old_leaf), np.asarray(new_leaf))
    assert not np.array_equal(np.asarray(ts.key), np.asarray(new.key))
    new, metrics = update(new)
    assert float(metrics["update_rejected"]) == 1.0 and int(new.failures) == 2

    good, metrics = update(ts)
    assert float(metrics["update_rejected"]) == 0.0 and int(good.failures) == 0
    assert np.isfinite(float(metrics["loss"]))
    moved = jax.tree.map(lambda a, b: bool(jnp.any(a != b)), ts.params, good.params)
    assert any(jax.tree.leaves(moved))


@pytest.mark.parametrize("name", ["ppo", "a2c"])
def test_vmapped_seeds_match_single_seeds(name, cartpole):
    """``init_seeds`` + ``train(seeds=True)`` equals training each seed on its own."""
    algo, config = ALGOS[name], TINY_CONFIGS[name]
    seeds, iterations = [0, 1], 3

    def run(ts, seeds_axis):
        metrics = []
        ts = train_lib.train(
            algo.update,
            ts,
            iterations,
            block_size=iterations,
            seeds=seeds_axis,
            callbacks=[lambda ts, m, first: metrics.append(m)],
        )
        return ts, metrics[0]

    batched_ts, batched = run(train_lib.init_seeds(algo.init, seeds, cartpole, config), True)
    for i, seed in enumerate(seeds):
        single_ts, single = run(algo.init(jax.random.PRNGKey(seed), cartpole, config), False)
        assert set(single) == set(batched)
        for key in set(single) - {"eval_seconds"}:  # eval_seconds: host wall time
            np.testing.assert_allclose(batched[key][:, i], single[key], rtol=1e-5, atol=1e-6, err_msg=key)
        for b, s in zip(jax.tree.leaves(batched_ts.params), jax.tree.leaves(single_ts.params), strict=True):
            np.testing.assert_allclose(np.asarray(b)[i], np.asarray(s), rtol=1e-5, atol=1e-6)


def test_metrics(cartpole):
    """PPO reports its optimisation diagnostics next to the common sampling metrics."""
    ts = ppo.init(jax.random.PRNGKey(0), cartpole, TINY_CONFIGS["ppo"])
    _, metrics = jax.jit(ppo.update)(ts)
    for key in ("kl", "approx_kl", "entropy", "clip_fraction", "policy_loss", "value_loss", "grad_norm"):
        assert np.isfinite(float(metrics[key])), key
    for key in ("env_steps", "return_stochastic", "update_rejected", "physics_overflow"):
        assert key in metrics
    assert not set(train_lib.EVAL_METRICS) & set(metrics)  # evaluation runs between calls
    assert float(metrics["kl"]) >= 0.0 and 0.0 <= float(metrics["clip_fraction"]) <= 1.0


def test_clip_fraction_and_ratio_at_sampling_params(cartpole):
    """At the sampling parameters the ratio is 1: nothing is clipped, the approximate KL is 0,
    and the PPO and plain policy-gradient losses agree in value and gradient."""
    ts = ppo.init(jax.random.PRNGKey(0), cartpole, TINY_CONFIGS["ppo"])
    ts, traj, _ = core.phase_sample(ts)
    batch = actor_critic.phase_advantages(ts, traj)
    joint = actor_critic.joint_params(ts)
    loss_and_grad = jax.value_and_grad(actor_critic.loss, argnums=1, has_aux=True)
    (clipped, aux), g_clip = loss_and_grad(ts, joint, batch, 0.2)
    (plain, _), g_plain = loss_and_grad(ts, joint, batch)
    assert float(aux["clip_fraction"]) == 0.0
    assert abs(float(aux["approx_kl"])) < 1e-6
    np.testing.assert_allclose(float(clipped), float(plain), rtol=1e-6)
    for a, b in zip(jax.tree.leaves(g_clip), jax.tree.leaves(g_plain), strict=True):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-5, atol=1e-7)


def test_a2c_step_is_the_shared_loss_without_clipping(cartpole):
    """An A2C update is one step of its optimizer on the shared actor-critic loss with no clipping,
    whose policy term at the sampling parameters (ratio 1) is ``-E[A]``, and reports that loss's
    terms."""
    config = TINY_CONFIGS["a2c"]
    ts = a2c.init(jax.random.PRNGKey(3), cartpole, config)
    new, metrics = jax.jit(a2c.update)(ts)

    sampled, traj, _ = core.phase_sample(ts)
    batch = actor_critic.phase_advantages(sampled, traj)
    joint = actor_critic.joint_params(sampled)
    (total, aux), grads = jax.value_and_grad(actor_critic.loss, argnums=1, has_aux=True)(sampled, joint, batch)
    updates, _ = a2c.optimizer(config).update(grads, sampled.opt_state, joint)
    expected = optax.apply_updates(joint, updates)
    for got, want in zip(jax.tree.leaves((new.params, new.value_params)), jax.tree.leaves(expected), strict=True):
        np.testing.assert_allclose(np.asarray(got), np.asarray(want), rtol=1e-5, atol=1e-6)
    for name in ("loss", "policy_loss", "value_loss", "entropy"):
        np.testing.assert_allclose(float(metrics[name]), float({**aux, "loss": total}[name]), rtol=1e-5, err_msg=name)
    np.testing.assert_allclose(
        float(aux["policy_loss"]), -float(core.weighted_mean(batch.advantages, batch.weights)), rtol=1e-5, atol=1e-7
    )
    assert float(aux["clip_fraction"]) == 0.0
    moved = jax.tree.map(lambda a, b: bool(jnp.any(a != b)), ts.params, new.params)
    assert any(jax.tree.leaves(moved))


@pytest.mark.parametrize(
    "algo, overrides, message",
    [
        (ppo, dict(num_envs=3, horizon=5, num_minibatches=4), "minibatches"),
        (ppo, dict(clip_eps=0.0), "clip_eps"),
        (ppo, dict(gae_lambda=1.5), "gae_lambda"),
        (a2c, dict(optimizer="sgd"), "optimizer"),
        (a2c, dict(lr=-1.0), "lr"),
    ],
)
def test_validate_rejects_impossible_settings(algo, overrides, message, cartpole):
    with pytest.raises(ValueError, match=message):
        algo.Config(**overrides).validate(cartpole)


def test_ppo_learning_rate_metric_is_the_optimizers_schedule():
    """The logged learning rate is optax's schedule at the iteration's first optimizer step:
    a linear decay to 0 over ``anneal_lr_iterations`` iterations, constant without annealing."""
    config = ppo.Config(lr=3e-4, anneal_lr_iterations=10, num_epochs=2, num_minibatches=4)
    for it in (0, 1, 5, 10, 12):
        expected = 3e-4 * max(0.0, 1.0 - it / 10)
        assert float(ppo.learning_rate(config, jnp.asarray(it))) == pytest.approx(expected, rel=1e-6, abs=1e-12)
    constant = ppo.Config(lr=3e-4)
    assert float(ppo.learning_rate(constant, jnp.asarray(7))) == pytest.approx(3e-4)
