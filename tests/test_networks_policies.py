"""MLP, distributions and policies against NumPy/SciPy references, under jit and without."""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.flatten_util import ravel_pytree
from scipy import integrate, special, stats

from jaxpg import distributions as D
from jaxpg.networks import CONV_TORSOS, MLP, ConvTorso
from jaxpg.policies import (
    CategoricalPolicy,
    GaussianPolicy,
    StateStdGaussianPolicy,
    ValueFunction,
    make_policy,
)


def maybe_jit(fn, use_jit, **kwargs):
    return jax.jit(fn, **kwargs) if use_jit else fn


NP_ACTIVATIONS = {
    "tanh": np.tanh,
    "relu": lambda x: np.maximum(x, 0.0),
    "elu": lambda x: np.where(x > 0, x, np.expm1(np.minimum(x, 0.0))),
    "gelu": lambda x: 0.5 * x * (1.0 + special.erf(x / np.sqrt(2.0))),
    "swish": lambda x: x / (1.0 + np.exp(-x)),
    "identity": lambda x: x,
}


# -- MLP -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("activation, use_jit", [("tanh", False)] + [(name, True) for name in NP_ACTIVATIONS])
def test_mlp_apply_matches_numpy(activation, use_jit):
    net = MLP((7, 5, 3), activation=activation)
    params = net.init(jax.random.key(0), 4)
    assert [(p["w"].shape, p["b"].shape) for p in params] == [((4, 7), (7,)), ((7, 5), (5,)), ((5, 3), (3,))]
    x = np.random.default_rng(0).normal(size=(2, 6, 4)).astype(np.float32)
    out = maybe_jit(net.apply, use_jit)(params, x)
    h = x.astype(np.float64)
    for i, layer in enumerate(params):
        h = h @ np.asarray(layer["w"], np.float64) + np.asarray(layer["b"], np.float64)
        if i < len(params) - 1:
            h = NP_ACTIVATIONS[activation](h)
    assert out.shape == (2, 6, 3) and out.dtype == jnp.float32
    np.testing.assert_allclose(out, h, rtol=1e-5, atol=1e-5)


def test_mlp_glorot_and_pytorch_bounds():
    n_in, n_out = 50, 200
    (layer,) = MLP((n_out,), kernel_init="glorot_uniform", bias_init="glorot_uniform").init(jax.random.key(1), n_in)
    w_lim, b_lim = math.sqrt(6 / (n_in + n_out)), math.sqrt(6 / (1 + n_out))
    assert np.abs(layer["w"]).max() <= w_lim and np.abs(layer["w"]).max() > 0.95 * w_lim
    assert np.abs(layer["b"]).max() <= b_lim and np.abs(layer["b"]).max() > 0.9 * b_lim
    (layer,) = MLP((n_out,), kernel_init="pytorch", bias_init="pytorch").init(jax.random.key(2), n_in)
    lim = 1 / math.sqrt(n_in)
    for leaf in (layer["w"], layer["b"]):
        assert np.abs(leaf).max() <= lim and np.abs(leaf).max() > 0.9 * lim
    (layer,) = MLP((n_out,), bias_init="zeros").init(jax.random.key(3), n_in)
    assert not np.any(layer["b"])


def test_mlp_orthogonal_and_final_scale():
    net = MLP(
        (16, 8, 2),
        kernel_init="orthogonal",
        bias_init="orthogonal",
        kernel_scale=math.sqrt(2),
        final_kernel_scale=0.01,
    )
    params = net.init(jax.random.key(0), 16)
    w0 = np.asarray(params[0]["w"], np.float64)
    np.testing.assert_allclose(w0.T @ w0, 2.0 * np.eye(16), atol=1e-5)
    w2 = np.asarray(params[2]["w"], np.float64)  # [8, 2]: orthonormal columns times 0.01
    np.testing.assert_allclose(w2.T @ w2, 1e-4 * np.eye(2), atol=1e-8)
    assert all(not np.any(p["b"]) for p in params)
    # With Glorot biases the final scale shrinks the last bias too.
    base = MLP((8, 2)).init(jax.random.key(5), 3)
    small = MLP((8, 2), final_kernel_scale=0.01).init(jax.random.key(5), 3)
    np.testing.assert_allclose(small[0]["w"], base[0]["w"])
    np.testing.assert_allclose(small[1]["w"], 0.01 * base[1]["w"], rtol=1e-6)
    np.testing.assert_allclose(small[1]["b"], 0.01 * base[1]["b"], rtol=1e-6)


def test_mlp_validation_and_hash():
    with pytest.raises(ValueError):
        MLP((4,), activation="sigmoidish")
    with pytest.raises(ValueError):
        MLP((4,), kernel_init="he")
    with pytest.raises(ValueError):
        MLP(())
    assert hash(MLP([4, 2])) == hash(MLP((4, 2)))


# -- Distributions -------------------------------------------------------------------------------


def _gaussian(rng, batch=(3, 4), a=2):
    mean = rng.normal(size=(*batch, a)).astype(np.float32)
    log_std = rng.normal(scale=0.5, size=(*batch, a)).astype(np.float32)
    return {"mean": jnp.asarray(mean), "log_std": jnp.asarray(log_std)}


@pytest.mark.parametrize("use_jit", [False, True])
def test_gaussian_functions_match_scipy(use_jit):
    rng = np.random.default_rng(0)
    p, q = _gaussian(rng), _gaussian(rng)
    x = rng.normal(size=(3, 4, 2)).astype(np.float32)
    mp, sp = np.asarray(p["mean"], np.float64), np.exp(np.asarray(p["log_std"], np.float64))
    mq, sq = np.asarray(q["mean"], np.float64), np.exp(np.asarray(q["log_std"], np.float64))
    log_prob = maybe_jit(D.gaussian_log_prob, use_jit)(p, x)
    np.testing.assert_allclose(log_prob, stats.norm.logpdf(x, mp, sp).sum(-1), rtol=1e-5)
    entropy = maybe_jit(D.gaussian_entropy, use_jit)(p)
    np.testing.assert_allclose(entropy, stats.norm.entropy(mp, sp).sum(-1), rtol=1e-5)
    np.testing.assert_allclose(D.gaussian_mode(p), p["mean"])
    kl = maybe_jit(D.gaussian_kl, use_jit)(p, q)
    # KL by numerical integration, one dimension at a time.
    ref = np.zeros(kl.shape)
    for idx in np.ndindex(*kl.shape):
        for i in range(2):
            a, b = stats.norm(mp[idx][i], sp[idx][i]), stats.norm(mq[idx][i], sq[idx][i])
            lo, hi = mp[idx][i] - 12 * sp[idx][i], mp[idx][i] + 12 * sp[idx][i]
            ref[idx] += integrate.quad(lambda t, a=a, b=b: a.pdf(t) * (a.logpdf(t) - b.logpdf(t)), lo, hi)[0]
    np.testing.assert_allclose(kl, ref, rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(D.gaussian_kl(p, p), 0.0, atol=1e-6)


def test_gaussian_broadcast_log_std_and_sampling():
    dist = {"mean": jnp.array([[1.0, -2.0]]).repeat(20000, 0), "log_std": jnp.log(jnp.array([0.5, 2.0]))}
    x = jax.jit(D.gaussian_sample)(dist, jax.random.key(0))
    assert x.shape == (20000, 2)
    np.testing.assert_allclose(x.mean(0), [1.0, -2.0], atol=0.05)
    np.testing.assert_allclose(x.std(0), [0.5, 2.0], rtol=0.03)
    full = {"mean": dist["mean"], "log_std": jnp.broadcast_to(dist["log_std"], dist["mean"].shape)}
    np.testing.assert_allclose(D.gaussian_log_prob(dist, x), D.gaussian_log_prob(full, x), rtol=1e-6)
    assert D.gaussian_entropy(dist).shape == (20000,)


@pytest.mark.parametrize("use_jit", [False, True])
def test_categorical_functions_match_numpy(use_jit):
    rng = np.random.default_rng(1)
    lp, lq = rng.normal(size=(2, 5, 4)).astype(np.float32)
    p, q = {"logits": jnp.asarray(lp)}, {"logits": jnp.asarray(lq)}
    pp, pq = special.softmax(lp.astype(np.float64), -1), special.softmax(lq.astype(np.float64), -1)
    a = rng.integers(0, 4, size=5)
    np.testing.assert_allclose(maybe_jit(D.categorical_log_prob, use_jit)(p, a), np.log(pp[np.arange(5), a]), rtol=1e-5)
    np.testing.assert_allclose(maybe_jit(D.categorical_entropy, use_jit)(p), stats.entropy(pp, axis=-1), rtol=1e-5)
    np.testing.assert_allclose(maybe_jit(D.categorical_kl, use_jit)(p, q), stats.entropy(pp, pq, axis=-1), rtol=1e-5)
    np.testing.assert_array_equal(D.categorical_mode(p), lp.argmax(-1))
    assert D.categorical_mode(p).dtype == jnp.int32


def test_categorical_sampling_frequencies():
    logits = jnp.log(jnp.array([0.1, 0.2, 0.7]))
    x = jax.jit(D.categorical_sample)({"logits": jnp.broadcast_to(logits, (30000, 3))}, jax.random.key(3))
    assert x.dtype == jnp.int32 and x.shape == (30000,)
    np.testing.assert_allclose(np.bincount(np.asarray(x), minlength=3) / 30000, [0.1, 0.2, 0.7], atol=0.01)


@pytest.mark.parametrize("kind", ["gaussian", "categorical"])
def test_fisher_metric_is_kl_hessian(kind):
    """``M`` equals the Hessian of ``KL(p || q)`` in ``q``'s parameters at ``q = p``."""
    rng = np.random.default_rng(2)
    if kind == "gaussian":
        dist = {
            "mean": jnp.asarray(rng.normal(size=3), jnp.float32),
            "log_std": jnp.asarray(rng.normal(size=3), jnp.float32),
        }
        kl, metric = D.gaussian_kl, D.gaussian_fisher_metric
    else:
        dist = {"logits": jnp.asarray(rng.normal(size=4), jnp.float32)}
        kl, metric = D.categorical_kl, D.categorical_fisher_metric
    flat, unravel = ravel_pytree(dist)
    hessian = jax.jit(jax.hessian(lambda f: kl(dist, unravel(f))))(flat)
    t = jnp.asarray(rng.normal(size=flat.shape), jnp.float32)
    np.testing.assert_allclose(ravel_pytree(metric(dist, unravel(t)))[0], hessian @ t, rtol=1e-4, atol=1e-5)


# -- Policies ------------------------------------------------------------------------------------

OBS = 5
POLICIES = {
    "gaussian": GaussianPolicy(action_size=3, hidden=(8, 8)),
    "state_std": StateStdGaussianPolicy(action_size=3, hidden=(8, 6)),
    "categorical": CategoricalPolicy(num_actions=4, hidden=(8,)),
}


@pytest.mark.parametrize("use_jit", [False, True])
@pytest.mark.parametrize("name", list(POLICIES))
def test_policy_interface(name, use_jit):
    policy = POLICIES[name]
    params = policy.init(jax.random.key(0), OBS)
    obs = jax.random.normal(jax.random.key(1), (7, OBS))
    if use_jit:  # the policy itself as a static argument: it must be hashable
        assert hash(policy) == hash(
            type(policy)(**{f.name: getattr(policy, f.name) for f in dataclasses.fields(policy)})
        )
        sample = jax.jit(lambda pol, p, o, k: pol.sample(p, o, k), static_argnums=0)
        action, log_prob = sample(policy, params, obs, jax.random.key(2))
    else:
        action, log_prob = policy.sample(params, obs, jax.random.key(2))
    if policy.discrete:
        assert action.shape == (7,) and action.dtype == jnp.int32
    else:
        assert action.shape == (7, 3) and action.dtype == jnp.float32
    assert log_prob.shape == (7,)
    np.testing.assert_allclose(maybe_jit(policy.log_prob, use_jit)(params, obs, action), log_prob, rtol=1e-5)
    assert maybe_jit(policy.entropy, use_jit)(params, obs).shape == (7,)
    mode = maybe_jit(policy.mode, use_jit)(params, obs)
    assert mode.shape == action.shape and mode.dtype == action.dtype
    other = policy.init(jax.random.key(9), OBS)
    kl = maybe_jit(policy.kl, use_jit)(params, other, obs)
    assert kl.shape == (7,) and np.all(kl > 0)
    np.testing.assert_allclose(policy.kl(params, params, obs), 0.0, atol=1e-6)
    if use_jit:  # extra leading axes, and vmap
        log_prob_fn = jax.jit(policy.log_prob)
        assert log_prob_fn(params, obs.reshape(7, 1, OBS), action.reshape(7, 1, *action.shape[1:])).shape == (
            7,
            1,
        )
        assert jax.jit(jax.vmap(policy.entropy, (None, 0)))(params, obs).shape == (7,)


def test_gaussian_policy_params_and_dist():
    policy = GaussianPolicy(action_size=2, hidden=[32, 32], log_std_init=-0.5, final_kernel_scale=0.01)
    params = policy.init(jax.random.key(0), 4)
    assert policy.hidden == (32, 32)
    assert set(params) == {"mean", "log_std"}
    np.testing.assert_allclose(params["log_std"], [-0.5, -0.5])
    dist = policy.dist(params, jnp.ones((3, 4)))
    assert dist["mean"].shape == dist["log_std"].shape == (3, 2)
    assert np.abs(dist["mean"]).max() < 0.05


def test_state_std_policy_matches_manual_forward():
    policy = StateStdGaussianPolicy(action_size=2, hidden=(16, 32), min_std=1e-3)
    params = policy.init(jax.random.key(0), 4)
    obs = np.random.default_rng(0).normal(size=(6, 4)).astype(np.float64)
    h = obs
    for layer in params["trunk"]:
        h = np.tanh(h @ np.asarray(layer["w"], np.float64) + np.asarray(layer["b"], np.float64))
    mean = h @ np.asarray(params["mean"][0]["w"], np.float64) + np.asarray(params["mean"][0]["b"], np.float64)
    pre = h @ np.asarray(params["std"][0]["w"], np.float64) + np.asarray(params["std"][0]["b"], np.float64)
    std = np.log1p(np.exp(pre)) + 1e-3
    dist = policy.dist(params, jnp.asarray(obs, jnp.float32))
    np.testing.assert_allclose(dist["mean"], mean, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(jnp.exp(dist["log_std"]), std, rtol=1e-5)


def test_value_function_and_make_policy():
    vf = ValueFunction(hidden=(16, 16))
    params = vf.init(jax.random.key(0), 3)
    assert [p["w"].shape for p in params] == [(3, 16), (16, 16), (16, 1)]
    assert vf.apply(params, jnp.ones((4, 2, 3))).shape == (4, 2)
    assert make_policy("gaussian", 3, False, hidden=(4,)) == GaussianPolicy(3, hidden=(4,))
    assert make_policy("categorical", 2, True).num_actions == 2
    assert isinstance(make_policy("state_std_gaussian", 1, False), StateStdGaussianPolicy)
    with pytest.raises(ValueError):
        make_policy("categorical", 2, False)
    with pytest.raises(ValueError):
        make_policy("beta", 2, False)


def _conv_reference(x: np.ndarray, w: np.ndarray, b: np.ndarray, stride: int) -> np.ndarray:
    """A VALID strided convolution by loops: ``x [H, W, C]``, ``w [k, k, C, O]`` -> ``[H', W', O]``."""
    k = w.shape[0]
    rows, cols = (x.shape[0] - k) // stride + 1, (x.shape[1] - k) // stride + 1
    out = np.zeros((rows, cols, w.shape[3]))
    for i in range(rows):
        for j in range(cols):
            patch = x[i * stride : i * stride + k, j * stride : j * stride + k, :]
            out[i, j] = np.tensordot(patch, w, axes=([0, 1, 2], [0, 1, 2])) + b
    return out


def test_conv_torso_matches_a_loop_convolution():
    """Flat ``[..., H*W*C]`` inputs read row-major, channels last; ReLU after every layer."""
    torso = ConvTorso((11, 9, 2), ((3, 3, 2), (4, 2, 1)))
    assert torso.feature_map_shapes() == [(5, 4, 3), (4, 3, 4)] and torso.out_size == 48 and torso.in_size == 198
    params = torso.init(jax.random.PRNGKey(0))
    params = [dict(layer, b=jnp.linspace(-0.3, 0.3, layer["b"].shape[0])) for layer in params]  # nonzero biases
    x = np.asarray(jax.random.normal(jax.random.PRNGKey(1), (2, 3, 198)))
    got = np.asarray(torso.apply(params, x))
    assert got.shape == (2, 3, 48)
    for idx in np.ndindex(2, 3):
        h = x[idx].reshape(11, 9, 2)
        for layer, (_, _, stride) in zip(params, torso.layers, strict=True):
            h = np.maximum(_conv_reference(h, np.asarray(layer["w"]), np.asarray(layer["b"]), stride), 0.0)
        np.testing.assert_allclose(got[idx], h.reshape(-1), rtol=1e-4, atol=1e-5)


def test_conv_torso_init_and_validation():
    torso = ConvTorso((80, 80, 1), CONV_TORSOS["nature"])
    assert torso.feature_map_shapes() == [(19, 19, 32), (8, 8, 64), (6, 6, 64)] and torso.out_size == 2304
    params = torso.init(jax.random.PRNGKey(3))
    assert [layer["w"].shape for layer in params] == [(8, 8, 1, 32), (4, 4, 32, 64), (3, 3, 64, 64)]
    # Orthogonal kernels with the ReLU gain: each [k*k*in, out] matrix has orthogonal columns of norm sqrt(2).
    w = np.asarray(params[1]["w"]).reshape(-1, 64)
    np.testing.assert_allclose(w.T @ w, 2.0 * np.eye(64), atol=1e-4)
    assert all(float(jnp.abs(layer["b"]).max()) == 0.0 for layer in params)
    with pytest.raises(ValueError, match="too small"):
        ConvTorso((20, 20, 1), CONV_TORSOS["nature"])
    with pytest.raises(ValueError, match="triples"):
        ConvTorso((20, 20, 1), ((8, 4),))
    assert hash(torso) == hash(ConvTorso((80, 80, 1), CONV_TORSOS["nature"]))


def test_policy_and_value_function_with_a_conv_torso():
    """The torso's features feed the MLP; params are ``{"conv", "mlp"}``; shapes as without it."""
    torso = ConvTorso((12, 12, 1), CONV_TORSOS["mnih2013"][:1])
    policy = CategoricalPolicy(num_actions=3, hidden=(5,), conv=torso)
    value_fn = ValueFunction(hidden=(4,), conv=torso)
    params = policy.init(jax.random.PRNGKey(0), 144)
    value_params = value_fn.init(jax.random.PRNGKey(1), 144)
    assert set(params) == {"conv", "mlp"} and params["mlp"][0]["w"].shape == (torso.out_size, 5)
    obs = jax.random.normal(jax.random.PRNGKey(2), (7, 2, 144))
    logits = policy.dist(params, obs)["logits"]
    features = torso.apply(params["conv"], obs)
    # Another program (the policy may flatten the leading axes before its products): float32 sums of
    # 5 terms of size <= ~1 in another order, a few ulps of 1: rtol 1e-5, atol 1e-6 for logits near 0.
    want = policy.logits_net.apply(params["mlp"], features)
    np.testing.assert_allclose(logits, want, rtol=1e-5, atol=1e-6)
    assert logits.shape == (7, 2, 3) and value_fn.apply(value_params, obs).shape == (7, 2)
    with pytest.raises(ValueError, match="reads"):
        policy.init(jax.random.PRNGKey(0), 100)


@pytest.mark.parametrize("network_init", ["glorot_uniform", "orthogonal"])
def test_policy_head_scale_scales_only_the_policys_last_layer(network_init):
    """``policy_head_scale`` multiplies the last layer of the policy network (kernel and bias) and
    nothing else: the hidden layers, the log-std and the value network are those of the default."""
    from jaxpg import envs
    from jaxpg.algos import core, ppo

    env = envs.make("inverted_pendulum")
    key = jax.random.PRNGKey(5)
    base, scaled = (
        ppo.Config(network_init=network_init, policy_hidden=(8, 8), policy_head_scale=s) for s in (1.0, 0.01)
    )
    (policy, value_fn), (policy_s, value_fn_s) = core.make_networks(env, base), core.make_networks(env, scaled)
    params, params_s = policy.init(key, env.observation_size), policy_s.init(key, env.observation_size)
    *hidden, head = params["mean"]
    *hidden_s, head_s = params_s["mean"]
    for layer, layer_s in zip(hidden, hidden_s, strict=True):
        np.testing.assert_array_equal(layer["w"], layer_s["w"])
        np.testing.assert_array_equal(layer["b"], layer_s["b"])
    np.testing.assert_allclose(head_s["w"], 0.01 * np.asarray(head["w"]), rtol=1e-6)
    np.testing.assert_allclose(head_s["b"], 0.01 * np.asarray(head["b"]), rtol=1e-6)
    assert float(jnp.max(jnp.abs(head["w"]))) > 0.05  # the default head is not already tiny
    np.testing.assert_array_equal(params["log_std"], params_s["log_std"])
    for leaf, leaf_s in zip(
        jax.tree.leaves(value_fn.init(key, env.observation_size)),
        jax.tree.leaves(value_fn_s.init(key, env.observation_size)),
        strict=True,
    ):
        np.testing.assert_array_equal(leaf, leaf_s)
    with pytest.raises(ValueError, match="policy_head_scale"):
        ppo.Config(policy_head_scale=0.0).validate(env)
