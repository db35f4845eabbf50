"""REINFORCE and VPG: the gradient against a hand-written NumPy gradient, the baseline's
advantages, config validation, multi-seed training against single seeds. Their learning tests
(REINFORCE's defaults on ``cartpole``, VPG's on ``inverted_pendulum``, two seeds each) are in
``tests/test_learning.py``."""

from __future__ import annotations

import types

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxpg import envs
from jaxpg import train as train_lib
from jaxpg.algos import core, reinforce, vpg
from jaxpg.policies import CategoricalPolicy, GaussianPolicy, StateStdGaussianPolicy, ValueFunction
from jaxpg.rollout import Trajectory

T, B, OBS = 7, 3, 4
GAMMA = 0.9


def maybe_jit(fn, use_jit):
    return jax.jit(fn) if use_jit else fn


# -- A fixed batch and the NumPy reference -------------------------------------------------------


def fixed_trajectory(discrete, seed=0):
    """``[T, B]`` transitions: column 0 runs on after a termination (continuing sampling),
    column 1 is truncated and then masked (episodic), column 2 is cut by the batch's end."""
    rng = np.random.default_rng(seed)
    terminated = np.zeros((T, B), bool)
    truncated = np.zeros((T, B), bool)
    valid = np.ones((T, B), np.float32)
    terminated[2, 0] = True
    truncated[4, 1], valid[5:, 1] = True, 0.0
    obs = rng.normal(size=(T, B, OBS)).astype(np.float32)
    actions = rng.integers(0, 3, size=(T, B)).astype(np.int32) if discrete else rng.normal(size=(T, B, 2))
    rewards = rng.normal(size=(T, B)).astype(np.float32)
    traj = Trajectory(
        obs=jnp.asarray(obs),
        actions=jnp.asarray(actions, jnp.int32 if discrete else jnp.float32),
        log_probs=jnp.zeros((T, B)),
        rewards=jnp.asarray(rewards),
        terminated=jnp.asarray(terminated),
        truncated=jnp.asarray(truncated),
        next_obs=jnp.asarray(obs),
        valid=jnp.asarray(valid),
        metrics={},
    )
    return traj, dict(obs=obs, actions=actions, rewards=rewards, done=terminated | truncated, valid=valid)


def numpy_returns(ref, normalization):
    """Discounted returns by a backward loop, normalised by explicit loops over episodes."""
    rewards, done, valid = ref["rewards"], ref["done"], ref["valid"]
    g = np.zeros((T, B))
    for b in range(B):
        future = 0.0
        for t in reversed(range(T)):
            future = rewards[t, b] + GAMMA * (0.0 if done[t, b] else future)
            g[t, b] = future
    if normalization == "none":
        return g
    if normalization == "batch":
        m = valid > 0
        return np.where(m, (g - g[m].mean()) / (g[m].std() + 1e-8), 0.0)
    out = np.zeros((T, B))
    for b in range(B):
        start = 0
        for t in range(T):
            if done[t, b] or t == T - 1:
                idx = [s for s in range(start, t + 1) if valid[s, b] > 0]
                if idx:
                    seg = g[idx, b]
                    out[idx, b] = (seg - seg.mean()) / (seg.std() + 1e-8)
                start = t + 1
    return out


def env_major(x):
    """``[T, B, ...] -> [B * T, ...]``, the order of jaxpg's flat batches (``jaxpg.rollout.flatten_samples``)."""
    return np.swapaxes(np.asarray(x), 0, 1).reshape((-1,) + np.shape(x)[2:])


def numpy_gradient(params, ref, advantages, entropy_coef, discrete):
    """Gradient of ``-sum(w A log pi) / sum(w) - c sum(w H) / sum(w)`` for a linear policy.

    Categorical: ``logits = x W + b``, ``d log pi(a) / d z = onehot(a) - p``,
    ``d H / d z = -p (log p + H)``. Gaussian: ``mu = x W + b`` with a global log-std ``s``,
    ``d log pi / d mu = (a - mu) / sigma^2``, ``d log pi / d s = z^2 - 1``, ``d H / d s = 1``.
    """
    x = ref["obs"].reshape(-1, OBS).astype(np.float64)
    w = ref["valid"].reshape(-1).astype(np.float64)
    a = advantages.reshape(-1)
    coef = w / w.sum()
    if discrete:
        layer = params[0]
        logits = x @ np.asarray(layer["w"], np.float64) + np.asarray(layer["b"], np.float64)
        logits -= logits.max(-1, keepdims=True)
        p = np.exp(logits) / np.exp(logits).sum(-1, keepdims=True)
        onehot = np.eye(3)[ref["actions"].reshape(-1)]
        entropy = -(p * np.log(p)).sum(-1)
        d_logits = -coef[:, None] * (a[:, None] * (onehot - p) - entropy_coef * p * (np.log(p) + entropy[:, None]))
        return {"w": x.T @ d_logits, "b": d_logits.sum(0)}
    layer = params["mean"][0]
    mu = x @ np.asarray(layer["w"], np.float64) + np.asarray(layer["b"], np.float64)
    log_std = np.asarray(params["log_std"], np.float64)
    z = (ref["actions"].reshape(-1, 2) - mu) / np.exp(log_std)
    d_mu = -coef[:, None] * a[:, None] * z / np.exp(log_std)
    d_log_std = -(coef[:, None] * a[:, None] * (z**2 - 1.0)).sum(0) - entropy_coef * coef.sum()
    return {"w": x.T @ d_mu, "b": d_mu.sum(0), "log_std": d_log_std}


def fake_state(policy, config, value_fn=None, value_params=None):
    """What ``phase_returns``/``loss`` read of a ``TrainState``, without an env."""
    return types.SimpleNamespace(
        policy=policy,
        config=config,
        obs_stats=core.RunningStats.create(OBS),
        value_fn=value_fn,
        value_params=value_params,
    )


@pytest.mark.parametrize("use_jit", [False, True])
@pytest.mark.parametrize("normalization", reinforce.RETURN_NORMALIZATIONS)
@pytest.mark.parametrize("discrete", [True, False], ids=["categorical", "gaussian"])
def test_reinforce_gradient_matches_numpy(discrete, normalization, use_jit):
    if discrete:
        policy = CategoricalPolicy(num_actions=3, hidden=())
    else:
        policy = GaussianPolicy(action_size=2, hidden=(), log_std_init=-0.3)
    params = policy.init(jax.random.key(1), OBS)
    config = reinforce.Config(gamma=GAMMA, return_normalization=normalization, entropy_coef=0.1)
    ts = fake_state(policy, config)
    traj, ref = fixed_trajectory(discrete)

    def grad(params, traj):
        batch = reinforce.phase_returns(ts, traj)
        return jax.grad(lambda p: reinforce.loss(ts, p, batch)[0])(params), batch

    grads, batch = maybe_jit(grad, use_jit)(params, traj)
    expected_adv = numpy_returns(ref, normalization)
    np.testing.assert_allclose(
        np.asarray(batch.advantages),
        env_major(expected_adv * ref["valid"]),
        rtol=1e-5,
        atol=1e-5,
    )
    expected = numpy_gradient(params, ref, expected_adv, 0.1, discrete)
    got = grads[0] if discrete else {**grads["mean"][0], "log_std": grads["log_std"]}
    for name, value in expected.items():
        np.testing.assert_allclose(np.asarray(got[name]), value, rtol=2e-4, atol=1e-5, err_msg=name)


@pytest.mark.parametrize("use_jit", [False, True])
def test_vpg_advantages_subtract_baseline_from_normalised_returns(use_jit):
    policy = CategoricalPolicy(num_actions=3, hidden=())
    value_fn = ValueFunction(hidden=(8,), activation="tanh")
    value_params = value_fn.init(jax.random.key(2), OBS)
    ts = fake_state(policy, vpg.Config(gamma=GAMMA, return_normalization="batch"), value_fn, value_params)
    traj, ref = fixed_trajectory(True)
    batch = maybe_jit(lambda traj: vpg.phase_advantages(ts, reinforce.phase_returns(ts, traj)), use_jit)(traj)
    g = env_major(numpy_returns(ref, "batch"))
    baseline = np.asarray(value_fn.apply(value_params, env_major(ref["obs"])))
    valid = env_major(ref["valid"])
    np.testing.assert_allclose(np.asarray(batch.value_targets), g, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(np.asarray(batch.advantages), (g - baseline) * valid, rtol=1e-5, atol=1e-5)


# -- Configs -------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cartpole():
    return envs.make("cartpole")


@pytest.mark.parametrize(
    "module, overrides",
    [
        (reinforce, dict(optimizer="sgd")),
        (reinforce, dict(lr=0.0)),
        (reinforce, dict(return_normalization="episodes")),
        (reinforce, dict(gamma=1.5)),
        (reinforce, dict(max_grad_norm=-1.0)),
        (reinforce, dict(sampling="batched")),
        (vpg, dict(value_batch_size=10_000)),
        (vpg, dict(value_epochs=0)),
    ],
)
def test_validate_rejects_impossible_settings(cartpole, module, overrides):
    with pytest.raises(ValueError):
        module.Config(num_envs=2, horizon=8, **overrides).validate(cartpole)


PRESETS = [
    (reinforce, "gymnasium_tutorial", "inverted_pendulum", StateStdGaussianPolicy),
    (reinforce, "kokoyi", "cartpole", CategoricalPolicy),
    (vpg, "lightning", "inverted_pendulum", GaussianPolicy),
]


@pytest.mark.parametrize("module, name, env_name, policy_type", PRESETS, ids=[p[1] for p in PRESETS])
def test_presets_build_their_seed_networks(module, name, env_name, policy_type):
    env = envs.make(env_name)
    config = module.Config(**module.PRESETS[name])
    config.validate(env)
    policy, _ = core.make_networks(env, config)
    assert type(policy) is policy_type and policy.hidden == config.policy_hidden


def test_reinforce_has_no_critic(cartpole):
    ts = reinforce.init(jax.random.PRNGKey(0), cartpole, reinforce.Config(num_envs=2, horizon=8))
    assert ts.value_params == {} and ts.value_opt_state == ()


# -- Training ------------------------------------------------------------------------------------

SMALL = dict(num_envs=4, horizon=32, eval_envs=2, eval_horizon=32, policy_hidden=(16,))


def block_metrics(module, ts, iterations, seeds=False):
    """The final state and the metrics of ``iterations`` iterations trained as one block."""
    history = []
    final = train_lib.train(
        module.update, ts, iterations, iterations, seeds=seeds, callbacks=[lambda s, m, i: history.append(m)]
    )
    return final, history[0]


# Metrics that discriminate between seeds 2 and 7 (checked: by more than 5 %).
SEED_DISCRIMINATING = ("policy_loss", "grad_norm", "return_stochastic")


@pytest.mark.parametrize("module", [reinforce, vpg], ids=["reinforce", "vpg"])
def test_multi_seed_training_matches_single_seeds(cartpole, module):
    """Two seeds trained in one vmapped program give the numbers of training each alone.

    The vmapped program is another program, whose batched products may sum in another float32
    order (CPU model, vector width), so what can be compared is:
    - Integer state exactly: the RNG keys and iteration counters after the block.
    - The first iteration starts from the same state: its rollout, returns, gradient and Adam step
      are float32 sums of at most a few thousand terms (relative difference <= ~1e-5, no solve to
      amplify it; Adam's first step ``g / (|g| + eps)`` only damps it), so every metric agrees to
      rtol 1e-4 (atol 1e-5 for numbers near zero).
    - The second iteration and the evaluation after it start from parameters that may differ in the
      last bits, where an episode can end a step earlier or later: no float tolerance follows from
      the computation. A seed mix-up or a shared key would break that each seed's vmapped metrics
      lie within a tenth of the gap between the two seeds' runs alone (``SEED_DISCRIMINATING``).
    """
    config = module.Config(**SMALL, **({"value_hidden": (16,)} if module is vpg else {}))
    seeds = [2, 7]
    together_state, together = block_metrics(
        module, train_lib.init_seeds(module.init, seeds, cartpole, config), 2, seeds=True
    )
    assert set(together) >= {
        "policy_loss",
        "entropy",
        "grad_norm",
        "kl",
        "return_stochastic",
        "return_mean_policy",
    }
    if module is vpg:
        assert "value_loss" in together
    alone = [block_metrics(module, module.init(jax.random.PRNGKey(seed), cartpole, config), 2) for seed in seeds]
    mismatches = []
    for i, (state, metrics) in enumerate(alone):
        np.testing.assert_array_equal(np.asarray(together_state.key[i]), np.asarray(state.key))
        assert int(together_state.iteration[i]) == int(state.iteration) == 2
        for name, value in metrics.items():
            if name != "eval_seconds":  # host wall time
                np.testing.assert_allclose(together[name][0, i], value[0], rtol=1e-4, atol=1e-5, err_msg=name)
        other = alone[1 - i][1]
        for name in SEED_DISCRIMINATING:
            own_gap, seed_gap = np.abs(together[name][:, i] - metrics[name]), np.abs(other[name] - metrics[name])
            assert np.all(seed_gap > 0.05 * np.abs(metrics[name])), (name, metrics[name], other[name])
            if not np.all(own_gap < 0.1 * seed_gap):
                mismatches.append((seeds[i], name, together[name][:, i].tolist(), metrics[name].tolist()))
    assert not mismatches, mismatches
