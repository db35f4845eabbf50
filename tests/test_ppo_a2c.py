"""PPO and A2C: the non-finite guard, validation, multi-seed training. Their learning tests (A2C on
``cartpole``, PPO on ``inverted_pendulum``, two seeds each) are in ``tests/test_learning.py``."""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
import numpy_reference as ref
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
# One optimizer step per iteration, from the sampling parameters, with an entropy bonus.
ONE_STEP_PPO = ppo.Config(**TINY, num_minibatches=1, num_epochs=1, value_clip_eps=0.2, entropy_coef=0.02)


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


def numpy_joint_loss(ts, batch, clip_eps=0.0, value_clip_eps=0.0):
    """``numpy_reference.actor_critic_loss`` of ``ts``'s categorical policy and value network on
    ``batch``, the old value predictions being the current ones (as at sampling time):
    ``(total, diagnostics, grads)`` in float64."""
    config = ts.config
    numpy_batch = {name: np.asarray(getattr(batch, name), np.float64) for name in ref.BATCH_FIELDS}
    numpy_batch["actions"] = np.asarray(batch.actions)
    joint = ref.to_numpy(actor_critic.joint_params(ts))
    values, _ = ref.mlp_forward(joint["value"], numpy_batch["obs"], config.value_activation)
    return ref.actor_critic_loss(
        "categorical",
        joint,
        numpy_batch,
        clip_eps,
        value_clip_eps,
        values[:, 0],
        config.value_coef,
        config.entropy_coef,
        config.policy_activation,
        config.value_activation,
    )


def check_metrics(metrics, want, want_total, grads):
    """The loss diagnostics of a single optimizer step from the sampling parameters: float32
    forward and backward passes of a batch of 32 through 8-unit networks differ from float64 by
    some tens of roundings of O(1) terms (below 1e-5)."""
    for name in ("policy_loss", "value_loss", "entropy"):
        np.testing.assert_allclose(float(metrics[name]), want[name], rtol=1e-5, atol=1e-5, err_msg=name)
    np.testing.assert_allclose(float(metrics["loss"]), want_total, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(float(metrics["grad_norm"]), np.linalg.norm(ref.flat(grads)), rtol=1e-5, atol=1e-5)


def test_metrics(cartpole):
    """One PPO step (one epoch of one minibatch) from the sampling parameters, against NumPy: its
    diagnostics are the joint loss's at ratio 1 (policy loss ``-E[A]``, value error, entropy, the
    gradient's norm; nothing clipped, approximate KL 0), the parameters move by the optimizer's step
    on the NumPy gradient, and the reported KL is the exact mean KL between the old and the new
    policy on the batch. The common sampling metrics are reported beside them."""
    config = ONE_STEP_PPO
    ts = ppo.init(jax.random.PRNGKey(0), cartpole, config)
    new, metrics = jax.jit(ppo.update)(ts)
    assert float(metrics["update_rejected"]) == 0.0

    sampled, traj, _ = core.phase_sample(ts)
    batch = actor_critic.phase_advantages(sampled, traj)
    want_total, want, grads = numpy_joint_loss(sampled, batch, config.clip_eps, config.value_clip_eps)
    check_metrics(metrics, want, want_total, grads)
    # At ratio 1 nothing is clipped and the approximate KL is 0 up to float32 rounding of the
    # log-probabilities (~1e-7, squared by the estimator).
    assert float(metrics["clip_fraction"]) == 0.0 and abs(float(metrics["approx_kl"])) < 1e-6

    joint = actor_critic.joint_params(sampled)
    updates, _ = ppo.optimizer(config).update(jax.tree.map(jnp.float32, grads), sampled.opt_state, joint)
    expected = optax.apply_updates(joint, updates)
    # Adam's first step is lr * g / (|g| + eps): a gradient error dg moves it by at most
    # lr * dg / eps = 100 dg, and dg (float32 against float64) stays below 1e-6.
    for got, want_leaf in zip(jax.tree.leaves((new.params, new.value_params)), jax.tree.leaves(expected), strict=True):
        np.testing.assert_allclose(np.asarray(got), np.asarray(want_leaf), rtol=0, atol=1e-4)

    obs = np.asarray(batch.obs, np.float64)
    old_dist = ref.policy_forward("categorical", ref.to_numpy(ts.params), obs, config.policy_activation)
    new_dist = ref.policy_forward("categorical", ref.to_numpy(new.params), obs, config.policy_activation)
    weights = np.asarray(batch.weights, np.float64)
    want_kl = np.sum(weights * ref.kl("categorical", old_dist, new_dist)) / weights.sum()
    assert want_kl > 0
    # A KL of ~1e-4 from float32 logits: ``sum p (log p - log q)`` cancels to ~1e-7 absolute.
    np.testing.assert_allclose(float(metrics["kl"]), want_kl, rtol=1e-3, atol=1e-7)

    for key in ("env_steps", "return_stochastic", "update_rejected", "physics_overflow", "learning_rate"):
        assert key in metrics
    assert not set(train_lib.EVAL_METRICS) & set(metrics)  # evaluation runs between calls


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


def test_a2c_step_is_one_optimizer_step_on_the_numpy_loss(cartpole):
    """An A2C update against NumPy: its reported loss terms are the unclipped joint loss at the
    sampling parameters (policy term ``-E[A]``, value error, entropy, gradient norm), and the
    parameters move by one step of its optimizer (clipping, then RMSprop) on the NumPy gradient."""
    config = TINY_CONFIGS["a2c"]
    ts = a2c.init(jax.random.PRNGKey(3), cartpole, config)
    new, metrics = jax.jit(a2c.update)(ts)

    sampled, traj, _ = core.phase_sample(ts)
    batch = actor_critic.phase_advantages(sampled, traj)
    want_total, want, grads = numpy_joint_loss(sampled, batch)
    assert abs(want["policy_loss"]) > 0.1  # advantages not normalised: -E[A] is no accidental 0
    np.testing.assert_allclose(want["policy_loss"], -np.mean(np.asarray(batch.advantages, np.float64)), rtol=1e-6)
    check_metrics(metrics, want, want_total, grads)

    joint = actor_critic.joint_params(sampled)
    updates, _ = a2c.optimizer(config).update(jax.tree.map(jnp.float32, grads), sampled.opt_state, joint)
    expected = optax.apply_updates(joint, updates)
    # RMSprop's first step is lr * g / sqrt((1 - decay) g^2 + eps), at most lr / sqrt(eps) ~ 1
    # times a gradient error, which stays below 1e-6 (float32 against float64).
    for got, want_leaf in zip(jax.tree.leaves((new.params, new.value_params)), jax.tree.leaves(expected), strict=True):
        np.testing.assert_allclose(np.asarray(got), np.asarray(want_leaf), rtol=0, atol=1e-5)
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
        (a2c, dict(anneal_lr_iterations=-1), "anneal_lr_iterations"),
    ],
)
def test_validate_rejects_impossible_settings(algo, overrides, message, cartpole):
    with pytest.raises(ValueError, match=message):
        algo.Config(**overrides).validate(cartpole)


@pytest.mark.parametrize("eps_in_sqrt", [True, False])
@pytest.mark.parametrize("anneal", [0, 4])
def test_a2c_rmsprop_against_numpy(eps_in_sqrt, anneal):
    """A2C's optimizer without clipping, three steps against NumPy's RMSprop:
    ``s <- decay s + (1 - decay) g^2``, step ``-lr_k g / sqrt(s + eps)`` (optax, MXNet) or
    ``-lr_k g / (sqrt(s) + eps)`` (PyTorch), ``lr_k = lr (1 - k / anneal)`` at step ``k``.
    The gradients are small enough (|g| ~ 1e-3, eps 1e-5) that the two placements differ 5-30x."""
    config = a2c.Config(
        optimizer="rmsprop",
        lr=7e-4,
        rmsprop_decay=0.99,
        eps=1e-5,
        max_grad_norm=0.0,
        rmsprop_eps_in_sqrt=eps_in_sqrt,
        anneal_lr_iterations=anneal,
    )
    rng = np.random.default_rng(0)
    params = {"w": jnp.asarray(rng.normal(size=(3, 4)), jnp.float32)}
    opt = a2c.optimizer(config)
    state = opt.init(params)
    want, avg = np.asarray(params["w"], np.float64), np.zeros((3, 4))
    for k in range(3):
        grad = 1e-3 * rng.normal(size=(3, 4))
        updates, state = opt.update({"w": jnp.asarray(grad, jnp.float32)}, state, params)
        params = optax.apply_updates(params, updates)
        avg = 0.99 * avg + 0.01 * grad**2
        lr = 7e-4 * (1 - k / anneal if anneal else 1.0)
        want = want - lr * grad / (np.sqrt(avg + 1e-5) if eps_in_sqrt else np.sqrt(avg) + 1e-5)
    # float32 RMSprop against float64: relative error ~1e-6 of each step, steps ~1e-4-1e-2.
    np.testing.assert_allclose(np.asarray(params["w"]), want, rtol=0, atol=1e-6)


def test_ppo_learning_rate_metric_is_the_optimizers_schedule():
    """The logged learning rate is optax's schedule at the iteration's first optimizer step:
    a linear decay to 0 over ``anneal_lr_iterations`` iterations, constant without annealing."""
    config = ppo.Config(lr=3e-4, anneal_lr_iterations=10, num_epochs=2, num_minibatches=4)
    for it in (0, 1, 5, 10, 12):
        expected = 3e-4 * max(0.0, 1.0 - it / 10)
        assert float(ppo.learning_rate(config, jnp.asarray(it))) == pytest.approx(expected, rel=1e-6, abs=1e-12)
    constant = ppo.Config(lr=3e-4)
    assert float(ppo.learning_rate(constant, jnp.asarray(7))) == pytest.approx(3e-4)


def test_ppo_standardised_value_targets_against_numpy(cartpole):
    """With ``normalize_value_targets``, PPO's value loss is taken against the batch's targets
    standardised by their statistics (the first batch: its own mean and variance, by NumPy), so
    it stays near 1 where raw targets 100 times larger give a loss in the thousands; the update
    leaves those statistics in the state, and the network's predictions in return units are
    what GAE sees next iteration."""
    scaled = dict(TINY, num_minibatches=1, num_epochs=1, reward_scaling=100.0)
    losses = {}
    for normalise in (False, True):
        config = ppo.Config(**scaled, normalize_value_targets=normalise)
        ts = ppo.init(jax.random.PRNGKey(5), cartpole, config)
        new, metrics = jax.jit(ppo.update)(ts)
        losses[normalise] = float(metrics["value_loss"])

        sampled, traj, _ = core.phase_sample(ts)
        batch = actor_critic.phase_advantages(sampled, traj)
        targets = np.asarray(batch.value_targets, np.float64)
        outputs = np.asarray(ts.value_fn.apply(ts.value_params, batch.obs), np.float64)
        if normalise:
            standardised = (targets - targets.mean()) / np.sqrt(targets.var() + 1e-8)
            want = np.mean(np.square(outputs - standardised))
            np.testing.assert_allclose(float(new.value_stats.mean[0]), targets.mean(), rtol=1e-5)
            np.testing.assert_allclose(float(new.value_stats.var[0]), targets.var(), rtol=1e-4)
            assert float(new.value_stats.count) == targets.size
            np.testing.assert_allclose(
                core.value_predictions(new, batch.obs),
                new.value_stats.mean[0] + new.value_stats.std[0] * new.value_fn.apply(new.value_params, batch.obs),
                rtol=1e-6,
            )
        else:
            want = np.mean(np.square(outputs - targets))
            assert float(new.value_stats.count) == 0.0  # untouched
        np.testing.assert_allclose(losses[normalise], want, rtol=1e-4)
    assert targets.std() > 50.0  # the raw targets are far from standardised
    assert losses[True] < 10.0 < 100.0 < losses[False]


def test_normalized_rewards_against_numpy():
    """``core.normalize_rewards`` is SB3's ``VecNormalize`` reward normalisation (NumPy,
    ``numpy_reference.normalized_rewards``): over 12 steps of 5 envs with episodes ending at random,
    invalid steps left out of the statistics, rewards large enough that some clip at 10; two calls of
    6 steps, the second from the first's normalizer, give the same as one call of 12."""
    rng = np.random.default_rng(0)
    t, b, gamma = 12, 5, 0.9
    rewards = rng.normal(1.0, 3.0, (t, b)) * rng.choice([1.0, 30.0], (t, b), p=[0.9, 0.1])
    ended = rng.random((t, b)) < 0.2
    valid = (rng.random((t, b)) < 0.9).astype(np.float64)
    want = ref.normalized_rewards(rewards, ended, valid, gamma)
    assert np.any(np.abs(want) == 10.0) and np.any(ended)

    args = [jnp.asarray(x, jnp.float32) for x in (rewards, ended, valid)]
    args[1] = args[1].astype(bool)
    got, normalizer = jax.jit(core.normalize_rewards, static_argnums=4)(core.RewardNormalizer.create(b), *args, gamma)
    np.testing.assert_allclose(np.asarray(got), want, rtol=1e-5, atol=1e-6)
    assert float(normalizer.stats.count) == valid.sum()

    first, mid = core.normalize_rewards(core.RewardNormalizer.create(b), *(x[:6] for x in args), gamma)
    second, _ = core.normalize_rewards(mid, *(x[6:] for x in args), gamma)
    np.testing.assert_allclose(np.concatenate([first, second]), want, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("name", ["ppo", "a2c"])
def test_normalize_rewards_in_the_update(name, cartpole):
    """With ``normalize_rewards`` the update learns from the normalised rewards of its samples and
    carries the normalizer (one statistic per sample drawn); off, the state has no normalizer and no
    extra leaves, so checkpoints of other runs keep their layout. The metrics report raw rewards."""
    algo = ALGOS[name]
    off = TINY_CONFIGS[name]
    on = dataclasses.replace(off, normalize_rewards=True)
    ts_off = algo.init(jax.random.PRNGKey(1), cartpole, off)
    ts_on = algo.init(jax.random.PRNGKey(1), cartpole, on)
    assert ts_off.reward_normalizer == ()
    assert len(jax.tree.leaves(ts_on)) == len(jax.tree.leaves(ts_off)) + 4

    new, metrics = jax.jit(algo.update)(ts_on)
    assert float(new.reward_normalizer.stats.count) == on.num_envs * on.horizon
    sampled, traj, _ = core.phase_sample(ts_on)
    ended = np.asarray(traj.terminated | traj.truncated)
    want = ref.normalized_rewards(np.asarray(traj.rewards), ended, np.asarray(traj.valid), on.gamma)
    _, learning = actor_critic.phase_rewards(sampled, traj)
    np.testing.assert_allclose(np.asarray(learning.rewards), want, rtol=1e-5)
    assert np.all(np.asarray(traj.rewards) == 1.0)  # cartpole's raw reward, which the metrics see
    np.testing.assert_allclose(float(metrics["mean_reward"]), 1.0)
    assert float(metrics["update_rejected"]) == 0.0
    returns = np.asarray(new.reward_normalizer.returns)
    assert np.all(np.isfinite(returns)) and np.any(returns > 0)


def numpy_ppo_epochs(ts, batch, traj, key):
    """PPO's epochs in NumPy (float64 losses and gradients by ``numpy_reference``; optax's
    clipping and Adam applied to them): from ``ts`` and ``batch`` as ``ppo.update`` hands them to
    its epochs (the value-target statistics have absorbed the batch), the same minibatch orders
    (``key`` split per epoch, one permutation each), each minibatch's advantages standardised on
    their own with ``normalize_minibatch_advantages``, and with ``recompute_advantages`` every
    epoch after the first on advantages and targets recomputed from ``traj`` by a plain GAE loop
    with the current value network. Returns the joint parameters after the last step."""
    config = ts.config
    opt = ppo.optimizer(config)
    joint = ref.to_numpy(actor_critic.joint_params(ts))
    opt_state = ts.opt_state
    steps, envs = traj.rewards.shape
    mean, std = float(ts.value_stats.mean[0]), float(ts.value_stats.std[0])

    def network_values(value_layers, obs):
        out, _ = ref.mlp_forward(value_layers, obs.reshape(-1, obs.shape[-1]), config.value_activation)
        return out[:, 0].reshape(obs.shape[:-1])

    def return_units(value_layers, obs):
        out = network_values(value_layers, obs)
        return mean + std * out if config.normalize_value_targets else out

    def env_major(x):
        return np.swapaxes(x, 0, 1).reshape(envs * steps)

    obs = np.asarray(ts.obs_stats.normalize(traj.obs), np.float64)
    next_obs = np.asarray(ts.obs_stats.normalize(traj.next_obs), np.float64)
    rewards = np.asarray(traj.rewards, np.float64) * config.reward_scaling
    terminated, truncated = np.asarray(traj.terminated), np.asarray(traj.truncated)
    first = {name: np.asarray(getattr(batch, name), np.float64) for name in ref.BATCH_FIELDS}
    first["actions"] = np.asarray(batch.actions)
    first_old_values = network_values(joint["value"], first["obs"])
    n = config.samples_per_iteration
    as_f32 = functools.partial(jax.tree.map, jnp.float32)
    for epoch, epoch_key in enumerate(jax.random.split(key, config.num_epochs)):
        data, old_values = first, first_old_values
        if config.recompute_advantages and epoch > 0:
            values = return_units(joint["value"], obs)
            advantages = ref.gae(
                rewards, values, return_units(joint["value"], next_obs), terminated, truncated,
                config.gamma, config.gae_lambda,
            )  # fmt: skip
            targets = advantages + values
            if config.normalize_advantages:
                advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
            if config.normalize_value_targets:
                targets = (targets - mean) / std
            data = {**first, "advantages": env_major(advantages), "value_targets": env_major(targets)}
            old_values = network_values(joint["value"], first["obs"])
        order = np.asarray(jax.random.permutation(epoch_key, n)).reshape(config.num_minibatches, -1)
        for idx in order:
            mb = {name: x[idx] for name, x in data.items()}
            if config.normalize_minibatch_advantages:
                mb["advantages"] = (mb["advantages"] - mb["advantages"].mean()) / (mb["advantages"].std() + 1e-8)
            _, _, grads = ref.actor_critic_loss(
                "categorical", joint, mb, config.clip_eps, config.value_clip_eps, old_values[idx],
                config.value_coef, config.entropy_coef, config.policy_activation, config.value_activation,
            )  # fmt: skip
            updates, opt_state = opt.update(as_f32(grads), opt_state, as_f32(joint))
            joint = ref.to_numpy(optax.apply_updates(as_f32(joint), updates))
    return joint


# Three epochs of two minibatches, a learning rate that moves the value network enough for the
# recomputed advantages to matter: with normalised value targets and value clipping (whose old
# predictions recomputation renews), and with minibatch advantages on their own.
EPOCH_VARIANTS = {
    "recompute": dict(recompute_advantages=True, normalize_value_targets=True, value_clip_eps=0.2),
    "minibatch_advantages": dict(normalize_minibatch_advantages=True, normalize_advantages=False),
}


@pytest.mark.parametrize("variant", sorted(EPOCH_VARIANTS))
def test_ppo_epochs_against_numpy(variant, cartpole):
    """``recompute_advantages`` and ``normalize_minibatch_advantages`` against a NumPy PPO
    (``numpy_ppo_epochs``): the update's parameters are the reference's, and not those of the
    reference with the option off."""
    overrides = EPOCH_VARIANTS[variant]
    config = ppo.Config(**{**TINY, "num_minibatches": 2, "num_epochs": 3, "lr": 1e-2, **overrides})
    ts = ppo.init(jax.random.PRNGKey(4), cartpole, config)
    new, metrics = jax.jit(ppo.update)(ts)
    assert float(metrics["update_rejected"]) == 0.0

    sampled, traj, key = core.phase_sample(ts)
    epochs_key, _ = jax.random.split(key)
    batch = actor_critic.phase_advantages(sampled, traj)
    fit_ts, fit_batch = core.standardise_value_targets(sampled, batch)
    got = ref.flat({"policy": new.params, "value": new.value_params})
    option = next(name for name in ("recompute_advantages", "normalize_minibatch_advantages") if name in overrides)
    errors = {}
    for on in (True, False):
        reference_ts = fit_ts.replace(config=dataclasses.replace(config, **{option: on}))
        want = ref.flat(numpy_ppo_epochs(reference_ts, fit_batch, traj, epochs_key))
        errors[on] = np.max(np.abs(got - want))
    # Six Adam steps of 1e-2 from float32 gradients: each step's size is lr * m / (sqrt(v) + 1e-5),
    # which a float32 gradient error (~1e-7 of the gradient) moves by at most lr * 1e-7 |g| / 1e-5
    # where the gradient is near Adam's epsilon; the option's own effect is some 1e-3.
    assert errors[True] < 2e-4, errors
    assert errors[False] > 10 * max(errors[True], 1e-4), errors


def test_minibatch_advantages_against_numpy():
    """A minibatch's advantages standardised over its valid samples by their population std (as
    ``jnp.std``, Brax; PyTorch's ``std`` in SB3 and CleanRL divides by n - 1, a factor 1.008 at 64
    samples), against NumPy; masked samples come out as 0 and take no part."""
    rng = np.random.default_rng(3)
    advantages = rng.normal(2.0, 5.0, 12)
    weights = (rng.random(12) < 0.75).astype(np.float64)
    valid = weights > 0
    want = np.zeros(12)
    want[valid] = (advantages[valid] - advantages[valid].mean()) / (advantages[valid].std() + 1e-8)
    zeros = jnp.zeros(12)
    batch = core.Batch(
        obs=zeros[:, None], actions=zeros, log_probs=zeros, advantages=jnp.asarray(advantages, jnp.float32),
        value_targets=zeros, weights=jnp.asarray(weights, jnp.float32),
    )  # fmt: skip
    got = ppo.minibatch_advantages(batch)
    np.testing.assert_allclose(np.asarray(got.advantages), want, rtol=1e-5, atol=1e-6)
    assert 3 <= valid.sum() < 12
