"""The losses and steps of PPO, A2C and TRPO, and advantage normalisation, against independent
float64 NumPy/SciPy references (``numpy_reference``) on batches built by hand with tiny networks:
no environment, no training run.

* PPO/A2C: the joint loss, each of its terms, its diagnostics and its gradient, on a batch whose
  probability ratios span [0.5, 1.5] with advantages of both signs, so that the clip is active on
  both sides; samples where the clipped term is the minimum carry no policy gradient.
* TRPO: the policy gradient and the natural direction against a dense Fisher solve, the full step
  ``sqrt(2 max_kl / x'Fx) x`` and the backtracking line search's choice against a NumPy rerun of
  its acceptance rule.
* ``returns.normalize``: a constant input comes out as zeros, not noise or NaN.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import numpy_reference as ref
import optax
import pytest

from jaxpg import returns
from jaxpg.algos import a2c, actor_critic, core, natural_gradient, ppo, trpo
from jaxpg.policies import CategoricalPolicy, GaussianPolicy, ValueFunction

# Float32 evaluation of terms of size O(1)-O(10) summed over at most 16 samples: each result may
# differ from the float64 reference by some tens of float32 roundings (eps 1.2e-7) of the largest
# term, i.e. below 1e-5 absolute, or 1e-5 relative on the larger values.
RTOL, ATOL = 1e-5, 1e-5


def hand_state(policy, value_fn, params, value_params, config) -> core.TrainState:
    """A ``TrainState`` holding only what losses and steps read (networks, parameters, config);
    there is no environment."""
    return core.TrainState(
        params=params,
        value_params=value_params,
        opt_state=(),
        value_opt_state=(),
        env_state=(),
        obs_stats=core.RunningStats.create(1),
        value_stats=core.RunningStats.create(1),
        key=jax.random.PRNGKey(0),
        iteration=jnp.zeros((), jnp.int32),
        failures=jnp.zeros((), jnp.int32),
        env=None,
        config=config,
        policy=policy,
        value_fn=value_fn,
    )


def assert_trees_close(got, want, rtol, atol, what):
    """Leaf by leaf, with the pytree structures equal."""
    assert jax.tree.structure(got) == jax.tree.structure(want), what
    for (path, a), b in zip(jax.tree_util.tree_leaves_with_path(got), jax.tree.leaves(want), strict=True):
        where = f"{what} {jax.tree_util.keystr(path)}"
        np.testing.assert_allclose(np.asarray(a), b, rtol=rtol, atol=atol, err_msg=where)


# -- PPO and A2C: the joint actor-critic loss ----------------------------------------------------

OBS_DIM = 3
# Probability ratios pi / pi_old of the 16 samples: both sides of PPO's clip range [0.8, 1.2] and
# inside it, each at least 0.05 from its edges, so that float32 rounding of the log-probabilities
# (ratio errors ~1e-6) cannot move a sample across an edge.
RATIOS = np.array([0.5, 0.6, 0.7, 0.75, 0.85, 0.9, 0.95, 1.0, 1.05, 1.1, 1.15, 1.25, 1.3, 1.4, 1.45, 1.5])
N = len(RATIOS)
CLIP_EPS, VALUE_CLIP_EPS = 0.2, 0.3
VALUE_COEF, ENTROPY_COEF = 0.7, 0.03  # neither default (0.5 and 0.0 / 0.01)
ACTIVATION = "tanh"
ACTIVATIONS = (ACTIVATION, ACTIVATION)  # of the policy and the value network
# (algorithm config, clip_eps, value_clip_eps) of the loss.
LOSS_CASES = {
    "a2c": (a2c.Config, 0.0, 0.0),
    "ppo": (ppo.Config, CLIP_EPS, 0.0),
    "ppo_value_clip": (ppo.Config, CLIP_EPS, VALUE_CLIP_EPS),
}


def actor_critic_problem(kind: str, config_cls=ppo.Config, entropy_coef: float = ENTROPY_COEF):
    """A tiny policy (``kind`` "gaussian": 2 action dims; "categorical": 3 actions) and value
    network (one hidden layer each) and a 16-sample batch whose ratios are ``RATIOS``:
    ``(ts, batch, numpy_batch, old_values [N])``.

    The sampling log-probabilities are ``log pi(a|s) - log RATIOS`` under the current parameters;
    advantages alternate in sign (so each side of the clip range holds both signs); two samples
    have weight 0; the old value predictions sit 0.1 (inside ``VALUE_CLIP_EPS``) or 0.6 (outside)
    from the current ones.
    """
    rng = np.random.default_rng(7)
    if kind == "gaussian":
        policy = GaussianPolicy(action_size=2, hidden=(5,), activation=ACTIVATION)
    else:
        policy = CategoricalPolicy(num_actions=3, hidden=(5,), activation=ACTIVATION)
    value_fn = ValueFunction(hidden=(4,), activation=ACTIVATION)
    params = policy.init(jax.random.PRNGKey(1), OBS_DIM)
    if kind == "gaussian":
        params["log_std"] = jnp.asarray([-0.3, 0.2], jnp.float32)
    value_params = value_fn.init(jax.random.PRNGKey(2), OBS_DIM)
    obs = rng.normal(size=(N, OBS_DIM)).astype(np.float32)

    dist = ref.policy_forward(kind, ref.to_numpy(params), obs, ACTIVATION)
    if kind == "gaussian":
        actions = (dist["mean"] + np.exp(dist["log_std"]) * rng.normal(size=dist["mean"].shape)).astype(np.float32)
    else:
        actions = rng.integers(0, 3, size=N).astype(np.int32)
    log_probs = (ref.log_prob(kind, dist, actions) - np.log(RATIOS)).astype(np.float32)
    advantages = (np.where(np.arange(N) % 2 == 0, 1.0, -1.0) * rng.uniform(0.5, 2.0, size=N)).astype(np.float32)
    weights = np.ones(N, np.float32)
    weights[[2, 13]] = 0.0
    values, _ = ref.mlp_forward(ref.to_numpy(value_params), obs, ACTIVATION)
    offsets = np.where(np.arange(N) % 3 == 0, 0.1, 0.6) * np.where(np.arange(N) % 4 < 2, 1.0, -1.0)
    old_values = (values[:, 0] - offsets).astype(np.float32)
    value_targets = rng.normal(size=N).astype(np.float32)

    numpy_batch = dict(
        obs=obs,
        actions=actions,
        log_probs=log_probs.astype(np.float64),
        advantages=advantages.astype(np.float64),
        value_targets=value_targets.astype(np.float64),
        weights=weights.astype(np.float64),
    )
    batch = core.Batch(
        obs=jnp.asarray(obs),
        actions=jnp.asarray(actions),
        log_probs=jnp.asarray(log_probs),
        advantages=jnp.asarray(advantages),
        value_targets=jnp.asarray(value_targets),
        weights=jnp.asarray(weights),
    )
    config = config_cls(value_coef=VALUE_COEF, entropy_coef=entropy_coef)
    return hand_state(policy, value_fn, params, value_params, config), batch, numpy_batch, old_values


@pytest.mark.parametrize("case", sorted(LOSS_CASES))
@pytest.mark.parametrize("kind", ["gaussian", "categorical"])
def test_joint_loss_and_gradient_match_numpy(kind, case):
    """``actor_critic.loss`` (PPO's with a clip, A2C's without), every diagnostic and the gradient in
    policy and value parameters against the NumPy loss and its hand-derived gradient; one
    ``gradient_step`` with plain SGD moves the parameters by minus that gradient and reports its
    norm."""
    config_cls, clip_eps, value_clip_eps = LOSS_CASES[case]
    ts, batch, numpy_batch, old_values = actor_critic_problem(kind, config_cls)
    joint = actor_critic.joint_params(ts)
    want_total, want, want_grads = ref.actor_critic_loss(
        kind,
        ref.to_numpy(joint),
        numpy_batch,
        clip_eps,
        value_clip_eps,
        old_values.astype(np.float64),
        VALUE_COEF,
        ENTROPY_COEF,
        *ACTIVATIONS,
    )
    if clip_eps > 0:  # the batch exercises the clip: some samples lose their policy gradient
        assert 0 < np.sum(~want["active"]) < N and 0 < want["clip_fraction"] < 1
    if value_clip_eps > 0:  # and the value clip: some samples lose their value gradient
        assert 0 < np.sum(want["value_frozen"]) < N

    loss_and_grad = jax.value_and_grad(actor_critic.loss, argnums=1, has_aux=True)
    (total, diagnostics), grads = loss_and_grad(ts, joint, batch, clip_eps, value_clip_eps, jnp.asarray(old_values))
    np.testing.assert_allclose(float(total), want_total, rtol=RTOL, atol=ATOL)
    for name in ("policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction"):
        np.testing.assert_allclose(float(diagnostics[name]), want[name], rtol=RTOL, atol=ATOL, err_msg=name)
    # Gradients: sums over the samples of products of O(1-10) factors, the same float32 budget.
    assert_trees_close(grads, want_grads, RTOL, ATOL, "gradient")

    sgd = optax.sgd(1.0)
    stepped, _, step_diagnostics = actor_critic.gradient_step(
        ts, sgd, joint, sgd.init(joint), batch, clip_eps, value_clip_eps, jnp.asarray(old_values)
    )
    moved = jax.tree.map(lambda p, g: p - g, ref.to_numpy(joint), want_grads)
    assert_trees_close(stepped, moved, RTOL, ATOL, "sgd step")
    np.testing.assert_allclose(float(step_diagnostics["loss"]), want_total, rtol=RTOL, atol=ATOL)
    norm = np.linalg.norm(ref.flat(want_grads))
    np.testing.assert_allclose(float(step_diagnostics["grad_norm"]), norm, rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("kind", ["gaussian", "categorical"])
def test_clipped_samples_carry_no_policy_gradient(kind):
    """PPO's surrogate ``min(r A, clip(r) A)`` is the constant ``clip(r) A`` where the clipped term
    is the smaller (``r > 1 + eps`` with ``A > 0``, ``r < 1 - eps`` with ``A < 0``): on those
    samples alone the policy gradient is exactly zero and the policy loss is ``-E[clip(r) A]``; on
    the others it is the NumPy gradient of ``-E[r A]``."""
    ts, batch, numpy_batch, _ = actor_critic_problem(kind, entropy_coef=0.0)
    adv = numpy_batch["advantages"]
    clipped_min = ((RATIOS > 1 + CLIP_EPS) & (adv > 0)) | ((RATIOS < 1 - CLIP_EPS) & (adv < 0))
    # Both sides of the range, both signs: samples the clip freezes and samples it does not.
    frozen_sides = {(r > 1, a > 0) for r, a, c in zip(RATIOS, adv, clipped_min, strict=True) if c}
    assert frozen_sides == {(True, True), (False, False)}
    outside = np.abs(RATIOS - 1) > CLIP_EPS
    assert np.any(outside & ~clipped_min)

    joint = actor_critic.joint_params(ts)
    loss_and_grad = jax.value_and_grad(actor_critic.loss, argnums=1, has_aux=True)
    frozen = batch.replace(weights=jnp.asarray(clipped_min, jnp.float32))
    (_, diagnostics), grads = loss_and_grad(ts, joint, frozen, CLIP_EPS)
    for leaf in jax.tree.leaves(grads["policy"]):
        np.testing.assert_array_equal(np.asarray(leaf), 0.0)
    clipped_ratios = np.clip(RATIOS, 1 - CLIP_EPS, 1 + CLIP_EPS)
    want = -np.mean((clipped_ratios * adv)[clipped_min])
    np.testing.assert_allclose(float(diagnostics["policy_loss"]), want, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(float(diagnostics["clip_fraction"]), 1.0)

    free = ~clipped_min
    free_batch = {**numpy_batch, "weights": free * 1.0}
    _, _, want_grads = ref.actor_critic_loss(
        kind, ref.to_numpy(joint), free_batch, 0.0, 0.0, None, 0.0, 0.0, *ACTIVATIONS
    )
    _, grads = loss_and_grad(ts, joint, batch.replace(weights=jnp.asarray(free, jnp.float32)), CLIP_EPS)
    assert_trees_close(grads["policy"], want_grads["policy"], RTOL, ATOL, "unclipped samples' gradient")
    assert np.linalg.norm(ref.flat(want_grads["policy"])) > 0.1


# -- TRPO: natural direction, full step and line search ------------------------------------------

TRPO_SAMPLES = 12
TRPO_DAMPING = 1e-3


def trpo_problem(advantage_sign: float, max_kl: float):
    """A Gaussian policy with a linear mean on 2-d states (parameters: ``log_std``, ``b``, ``w``
    [2]) and a 12-sample batch at the sampling parameters (ratios 1), one sample of weight 0:
    ``(ts, batch, numpy_batch, numpy_params)``.

    The advantages are ``advantage_sign * (z^2 - 1)`` plus noise (``z`` the action's standard
    score), so that the natural direction widens (+1) or narrows (-1) the policy: the KL of a step
    that narrows it grows faster than its quadratic model, of one that widens it slower.
    """
    rng = np.random.default_rng(11)
    policy = GaussianPolicy(action_size=1, hidden=(), activation=ACTIVATION)
    params = {
        "log_std": jnp.asarray([-0.2], jnp.float32),
        "mean": [{"w": jnp.asarray([[0.4], [-0.7]], jnp.float32), "b": jnp.asarray([0.1], jnp.float32)}],
    }
    numpy_params = ref.to_numpy(params)
    obs = rng.normal(size=(TRPO_SAMPLES, 2)).astype(np.float32)
    dist = ref.policy_forward("gaussian", numpy_params, obs, ACTIVATION)
    noise = rng.normal(size=dist["mean"].shape)
    actions = (dist["mean"] + np.exp(dist["log_std"]) * noise).astype(np.float32)
    z = (actions[:, 0] - dist["mean"][:, 0]) / np.exp(dist["log_std"][:, 0])
    advantages = (advantage_sign * (z**2 - 1.0) + 0.5 * rng.normal(size=TRPO_SAMPLES)).astype(np.float32)
    weights = np.ones(TRPO_SAMPLES, np.float32)
    weights[5] = 0.0
    log_probs = ref.log_prob("gaussian", dist, actions).astype(np.float32)
    numpy_batch = dict(obs=obs, actions=actions, log_probs=log_probs, advantages=advantages, weights=weights)
    numpy_batch = {k: v.astype(np.float64) for k, v in numpy_batch.items()}
    batch = core.Batch(
        obs=jnp.asarray(obs),
        actions=jnp.asarray(actions),
        log_probs=jnp.asarray(log_probs),
        advantages=jnp.asarray(advantages),
        value_targets=jnp.zeros(TRPO_SAMPLES),
        weights=jnp.asarray(weights),
    )
    config = trpo.Config(max_kl=max_kl, cg_damping=TRPO_DAMPING, cg_iters=10)
    return hand_state(policy, None, params, {}, config), batch, numpy_batch, numpy_params


def numpy_policy_gradient(params, batch) -> np.ndarray:
    """``[P]`` gradient of ``E_w[r A]`` at ratio 1: ``E_w[A grad log pi]``, with ``grad log pi`` of a
    Gaussian: ``(a - mu) / sigma^2`` in the mean, ``z^2 - 1`` in ``log_std``."""
    dist = ref.policy_forward("gaussian", params, batch["obs"], ACTIVATION)
    var = np.exp(2.0 * dist["log_std"])
    residual = batch["actions"] - dist["mean"]
    c = batch["weights"] / batch["weights"].sum()
    upstream = {"mean": (c * batch["advantages"])[:, None] * residual / var}
    upstream["log_std"] = (c * batch["advantages"])[:, None] * (residual**2 / var - 1.0)
    return ref.flat(ref.policy_backward("gaussian", params, dist, upstream, ACTIVATION))


def numpy_line_search(params, batch, grad, direction, config) -> dict:
    """TRPO's step, rewritten: the full step ``sqrt(2 max_kl / x'(F + damping I)x)`` along
    ``x``, then the first of the fractions ``backtrack_ratio^k`` whose mean KL is within
    ``max_kl`` and whose surrogate improvement is positive and at least ``accept_ratio`` times the
    first-order prediction ``fraction * full_step * g'x``. Returns the full step, the index taken
    (``None``: none) and each candidate's KL, improvement and predicted improvement."""
    fisher = ref.gaussian_fisher(params, batch["obs"], batch["weights"], ACTIVATION)
    curvature = direction @ (fisher + config.cg_damping * np.eye(len(direction))) @ direction
    full_step = np.sqrt(2.0 * config.max_kl / curvature)
    c = batch["weights"] / batch["weights"].sum()
    old = ref.policy_forward("gaussian", params, batch["obs"], ACTIVATION)
    old_log_prob = ref.log_prob("gaussian", old, batch["actions"])
    kls, improvements, predicted = [], [], []
    for k in range(config.backtracks):
        fraction = config.backtrack_ratio**k
        candidate = ref.unflat(ref.flat(params) + fraction * full_step * direction, params)
        new = ref.policy_forward("gaussian", candidate, batch["obs"], ACTIVATION)
        ratio = np.exp(ref.log_prob("gaussian", new, batch["actions"]) - old_log_prob)
        kls.append(c @ ref.kl("gaussian", old, new))
        improvements.append(c @ ((ratio - 1.0) * batch["advantages"]))
        predicted.append(fraction * full_step * grad @ direction)
    kls, improvements, predicted = np.array(kls), np.array(improvements), np.array(predicted)
    ok = (kls <= config.max_kl) & (improvements > 0) & (improvements >= config.accept_ratio * predicted)
    first = int(np.argmax(ok)) if ok.any() else None
    return dict(full_step=full_step, first=first, kl=kls, improvement=improvements, predicted=predicted)


def test_trpo_gradient_and_natural_direction_match_dense_solve():
    """The policy gradient against ``E_w[A grad log pi]`` written out, and the conjugate-gradient
    direction against ``numpy.linalg.solve`` with the dense Fisher matrix plus damping."""
    ts, batch, numpy_batch, numpy_params = trpo_problem(1.0, 0.01)
    want_grad = numpy_policy_gradient(numpy_params, numpy_batch)
    grad = natural_gradient.phase_gradient(ts, batch)
    np.testing.assert_allclose(np.asarray(grad), want_grad, rtol=RTOL, atol=ATOL)

    fisher = ref.gaussian_fisher(numpy_params, numpy_batch["obs"], numpy_batch["weights"], ACTIVATION)
    damped = fisher + TRPO_DAMPING * np.eye(len(want_grad))
    # A well-conditioned 4 x 4 system: float32 conjugate gradient reaches a relative error of a few
    # condition numbers times float32's eps, ~1e-6; 1e-4 leaves room for its ten iterations.
    assert np.linalg.cond(damped) < 10
    cg = natural_gradient.phase_natural_gradient(ts, batch, grad)
    np.testing.assert_allclose(np.asarray(cg.x), np.linalg.solve(damped, want_grad), rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize(
    "advantage_sign, max_kl, first",
    [
        (1.0, 0.01, 0),  # the full step is taken
        (-1.0, 0.01, 1),  # the full step's KL overshoots max_kl: one backtrack
        (1.0, 10.0, 2),  # the long steps improve the surrogate too little: two backtracks
    ],
    ids=["full-step", "kl-backtrack", "improvement-backtrack"],
)
def test_trpo_line_search_matches_numpy(advantage_sign, max_kl, first):
    """``trpo.line_search`` along the dense solve's direction: the full step ``sqrt(2 max_kl /
    x'Fx)``, the candidate it accepts, its KL, improvement and new parameters, against the NumPy
    rerun of the acceptance rule on the same problem."""
    ts, batch, numpy_batch, numpy_params = trpo_problem(advantage_sign, max_kl)
    config = ts.config
    grad = numpy_policy_gradient(numpy_params, numpy_batch)
    fisher = ref.gaussian_fisher(numpy_params, numpy_batch["obs"], numpy_batch["weights"], ACTIVATION)
    direction = np.linalg.solve(fisher + TRPO_DAMPING * np.eye(len(grad)), grad).astype(np.float32)
    want = numpy_line_search(numpy_params, numpy_batch, grad, direction.astype(np.float64), config)
    assert want["first"] == first
    # Every decision up to the accepted candidate is clear by more than 1 %, so float32 evaluation
    # (relative errors ~1e-5 after the KL's and the surrogate's cancellations) cannot flip one.
    decided = slice(0, first + 1)
    assert np.all(np.abs(want["kl"][decided] / max_kl - 1.0) > 0.01)
    margin = want["improvement"][decided] / want["predicted"][decided] - config.accept_ratio
    assert np.all(np.abs(margin) > 0.01)

    new_params, info = trpo.line_search(ts, batch, jnp.asarray(grad, jnp.float32), jnp.asarray(direction))
    step = config.backtrack_ratio**first * want["full_step"]
    assert float(info["line_search_accepted"]) == 1.0
    assert float(info["line_search_backtracks"]) == first
    # The step length is a float32 square root of a 4-term quadratic form: ~1e-6 relative.
    np.testing.assert_allclose(float(info["step_length"]), step, rtol=RTOL)
    np.testing.assert_allclose(
        ref.flat(ref.to_numpy(new_params)), ref.flat(numpy_params) + step * direction, rtol=RTOL, atol=ATOL
    )
    # KL and improvement are small differences of O(1) float32 terms (KL ~ max_kl from
    # ``1 + ...  - 1`` per sample, the improvement from two surrogates): absolute errors ~1e-7, so
    # 1e-4 relative on values of 0.01 and more.
    np.testing.assert_allclose(float(info["kl"]), want["kl"][first], rtol=1e-4, atol=1e-7)
    np.testing.assert_allclose(float(info["surrogate_improvement"]), want["improvement"][first], rtol=1e-4, atol=1e-7)


# -- Advantage normalisation ---------------------------------------------------------------------


@pytest.mark.parametrize("value", [0.0, 0.1, 3.7, -42.1, 100.3])
def test_normalize_constant_input_is_zero(value):
    """A constant array has no spread: it standardises to zeros, finite, with or without a mask
    (and whatever the masked-out entries hold). Its float32 mean can miss the constant by an ulp,
    which a division by ``std + eps`` alone would blow up to values of size 1."""
    x = jnp.full((23, 6), value, jnp.float32)
    np.testing.assert_array_equal(np.asarray(returns.normalize(x)), 0.0)
    mask = np.arange(23 * 6).reshape(23, 6) % 3 != 0
    noisy = jnp.where(mask, x, jnp.asarray(np.random.default_rng(0).normal(size=(23, 6)), jnp.float32))
    np.testing.assert_array_equal(np.asarray(returns.normalize(noisy, mask)), 0.0)
    one_valid = np.zeros((23, 6), bool)
    one_valid[4, 2] = True
    np.testing.assert_array_equal(np.asarray(returns.normalize(noisy, one_valid)), 0.0)
    np.testing.assert_array_equal(np.asarray(returns.normalize(noisy, np.zeros((23, 6), bool))), 0.0)


def test_normalize_spread_below_float32_resolution_stays_finite():
    """Entries that differ by so little that their variance underflows to 0 in float32 (deviations
    ~1e-30, squares ~1e-60): ``eps`` keeps the division finite and the result at the entries' own
    scale, ``deviation / eps`` ~1e-22, with or without a mask."""
    x = jnp.asarray([0.0, 1e-30] * 4, jnp.float32)
    assert float(jnp.std(x)) == 0.0
    for mask in (None, np.asarray([True, True, True, False] * 2)):
        out = np.asarray(returns.normalize(x, mask))
        assert np.all(np.isfinite(out)) and np.max(np.abs(out)) < 1e-20
