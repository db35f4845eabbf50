"""Independent float64 NumPy/SciPy references for the tests of jaxpg's losses and steps.

MLP forward and backward passes, the log-densities, entropies and KL divergences of diagonal
Gaussian and categorical policies (SciPy's, or their textbook closed forms written out), the joint
actor-critic loss of PPO and A2C with its gradient derived by hand, GAE as a plain loop, and the
dense Fisher matrix of a Gaussian policy. Nothing here calls jaxpg: parameters come in as the
pytrees jaxpg uses (``[{"w": [in, out], "b": [out]}, ...]`` per MLP), converted to NumPy.
"""

from __future__ import annotations

from typing import Any

import jax
import numpy as np
from scipy import special, stats

# The activation and its derivative written in terms of the activation's output.
ACTIVATIONS = {
    "tanh": (np.tanh, lambda h: 1.0 - h**2),
    "relu": (lambda z: np.maximum(z, 0.0), lambda h: (h > 0.0).astype(np.float64)),
}


# The fields of a training batch that ``actor_critic_loss`` reads.
BATCH_FIELDS = ("obs", "actions", "log_probs", "advantages", "value_targets", "weights")


def to_numpy(tree: Any) -> Any:
    """Every leaf of ``tree`` as a float64 NumPy array."""
    return jax.tree.map(lambda x: np.asarray(x, np.float64), tree)


def flat(tree: Any, per_sample: bool = False) -> np.ndarray:
    """The leaves of ``tree`` concatenated in pytree order (``jax.flatten_util.ravel_pytree``'s):
    ``[P]``, or ``[N, P]`` for leaves with a leading per-sample axis."""
    leaves = [np.asarray(leaf, np.float64) for leaf in jax.tree.leaves(tree)]
    if per_sample:
        return np.concatenate([leaf.reshape(leaf.shape[0], -1) for leaf in leaves], axis=1)
    return np.concatenate([leaf.reshape(-1) for leaf in leaves])


def unflat(vector: np.ndarray, like: Any) -> Any:
    """``flat``'s inverse: the ``[P]`` vector as a pytree shaped like ``like``."""
    leaves, treedef = jax.tree.flatten(like)
    out, at = [], 0
    for leaf in leaves:
        size = np.size(leaf)
        out.append(np.asarray(vector[at : at + size], np.float64).reshape(np.shape(leaf)))
        at += size
    return jax.tree.unflatten(treedef, out)


def mlp_forward(layers: list[dict], x: np.ndarray, activation: str) -> tuple[np.ndarray, list[np.ndarray]]:
    """``x [N, in] -> (out [N, out], inputs)``: ``act(x W_1 + b_1) ... W_L + b_L``; ``inputs[l]``
    is the ``[N, in_l]`` input of layer ``l`` (kept for ``mlp_backward``)."""
    act, _ = ACTIVATIONS[activation]
    h = np.asarray(x, np.float64)
    inputs = []
    for i, layer in enumerate(layers):
        inputs.append(h)
        h = h @ layer["w"] + layer["b"]
        if i < len(layers) - 1:
            h = act(h)
    return h, inputs


def mlp_backward(
    layers: list[dict], inputs: list[np.ndarray], upstream: np.ndarray, activation: str, per_sample: bool = False
) -> list[dict]:
    """Gradient of ``sum_i upstream_i . out_i`` in the layers' parameters (``upstream [N, out]``):
    leaves shaped like the parameters, or with a leading ``[N]`` axis (one gradient per sample)
    when ``per_sample``."""
    _, derivative = ACTIVATIONS[activation]
    grads: list[dict] = [{} for _ in layers]
    delta = np.asarray(upstream, np.float64)  # gradient at layer i's pre-activation output
    for i in reversed(range(len(layers))):
        h_in = inputs[i]
        if per_sample:
            grads[i] = {"w": h_in[:, :, None] * delta[:, None, :], "b": delta}
        else:
            grads[i] = {"w": h_in.T @ delta, "b": delta.sum(axis=0)}
        if i > 0:
            delta = (delta @ layers[i]["w"].T) * derivative(h_in)
    return grads


# -- Distributions -------------------------------------------------------------------------------


def gaussian_log_prob(mean: np.ndarray, log_std: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """``[N]`` log-density of ``actions [N, A]`` under ``N(mean, diag(exp(2 log_std)))`` (SciPy)."""
    return stats.norm.logpdf(actions, loc=mean, scale=np.exp(log_std)).sum(axis=-1)


def gaussian_entropy(log_std: np.ndarray) -> np.ndarray:
    """``[...]`` entropy of a diagonal Gaussian with ``log_std [..., A]`` (SciPy)."""
    return stats.norm(scale=np.exp(log_std)).entropy().sum(axis=-1)


def gaussian_kl(mean_p: np.ndarray, log_std_p: np.ndarray, mean_q: np.ndarray, log_std_q: np.ndarray) -> np.ndarray:
    """``[N]`` KL(p || q) of diagonal Gaussians, the closed form summed over the ``A`` axes:
    ``log(s_q / s_p) + (s_p^2 + (m_p - m_q)^2) / (2 s_q^2) - 1/2``."""
    var_p, var_q = np.exp(2.0 * log_std_p), np.exp(2.0 * log_std_q)
    per_axis = log_std_q - log_std_p + (var_p + (mean_p - mean_q) ** 2) / (2.0 * var_q) - 0.5
    return per_axis.sum(axis=-1)


def categorical_log_prob(logits: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """``[N]`` log-probability of the integer ``actions [N]``."""
    return special.log_softmax(logits, axis=-1)[np.arange(len(actions)), actions]


def categorical_entropy(logits: np.ndarray) -> np.ndarray:
    """``[N]`` entropy of ``softmax(logits)`` (SciPy)."""
    return stats.entropy(special.softmax(logits, axis=-1), axis=-1)


def categorical_kl(logits_p: np.ndarray, logits_q: np.ndarray) -> np.ndarray:
    """``[N]`` KL(p || q) of two categoricals (SciPy's relative entropy)."""
    return stats.entropy(special.softmax(logits_p, axis=-1), special.softmax(logits_q, axis=-1), axis=-1)


# -- Policies ------------------------------------------------------------------------------------


def policy_forward(kind: str, params: Any, obs: np.ndarray, activation: str) -> dict[str, Any]:
    """The distribution of a ``"gaussian"`` policy (MLP mean, global ``log_std``) or a
    ``"categorical"`` one (MLP logits) at ``obs [N, obs_dim]``, with the MLP's layer inputs."""
    if kind == "gaussian":
        mean, inputs = mlp_forward(params["mean"], obs, activation)
        return {"mean": mean, "log_std": np.broadcast_to(params["log_std"], mean.shape), "inputs": inputs}
    logits, inputs = mlp_forward(params, obs, activation)
    return {"logits": logits, "inputs": inputs}


def log_prob(kind: str, dist: dict[str, Any], actions: np.ndarray) -> np.ndarray:
    """``[N]`` log-probability of ``actions`` under ``policy_forward``'s distribution."""
    if kind == "gaussian":
        return gaussian_log_prob(dist["mean"], dist["log_std"], actions)
    return categorical_log_prob(dist["logits"], actions)


def entropy(kind: str, dist: dict[str, Any]) -> np.ndarray:
    """``[N]`` entropy of ``policy_forward``'s distribution."""
    if kind == "gaussian":
        return gaussian_entropy(dist["log_std"])
    return categorical_entropy(dist["logits"])


def kl(kind: str, dist_p: dict[str, Any], dist_q: dict[str, Any]) -> np.ndarray:
    """``[N]`` KL(p || q) of two of ``policy_forward``'s distributions."""
    if kind == "gaussian":
        return gaussian_kl(dist_p["mean"], dist_p["log_std"], dist_q["mean"], dist_q["log_std"])
    return categorical_kl(dist_p["logits"], dist_q["logits"])


def policy_backward(kind: str, params: Any, dist: dict[str, Any], upstream: dict[str, np.ndarray], activation: str):
    """Gradient in the policy parameters of ``sum_i upstream_i . dist_i``, where ``upstream`` holds
    ``[N, A]`` arrays for ``mean`` and ``log_std`` (Gaussian; the global ``log_std`` gets their sum
    over samples) or ``logits`` (categorical)."""
    if kind == "gaussian":
        mean_grads = mlp_backward(params["mean"], dist["inputs"], upstream["mean"], activation)
        return {"log_std": upstream["log_std"].sum(axis=0), "mean": mean_grads}
    return mlp_backward(params, dist["inputs"], upstream["logits"], activation)


def actor_critic_loss(
    kind: str,
    joint: dict[str, Any],
    batch: dict[str, np.ndarray],
    clip_eps: float,
    value_clip_eps: float,
    old_values: np.ndarray | None,
    value_coef: float,
    entropy_coef: float,
    policy_activation: str,
    value_activation: str,
) -> tuple[float, dict[str, float], dict[str, Any]]:
    """PPO's and A2C's joint loss ``-E_w[surrogate] + value_coef E_w[value error] - entropy_coef
    E_w[H]`` and its gradient, by hand.

    ``joint``: ``{"policy": params, "value": value MLP layers}``; ``batch``: ``obs [N, d]``,
    ``actions``, ``log_probs [N]`` (sampling policy), ``advantages [N]``, ``value_targets [N]``,
    ``weights [N]``. ``E_w`` is the mean weighted by ``weights`` (over ``max(sum w, 1)``). The
    surrogate is ``r A`` (``clip_eps`` 0) or ``min(r A, clip(r, 1 - eps, 1 + eps) A)``; the value
    error ``(V - R)^2``, or with ``value_clip_eps`` > 0 the larger of that and
    ``(old + clip(V - old, -+ eps) - R)^2``.

    Returns ``(total, diagnostics, grads)``: diagnostics ``policy_loss``, ``value_loss``,
    ``entropy``, ``approx_kl`` (``E_w[(r - 1) - log r]``), ``clip_fraction`` (``E_w[|r - 1| > eps]``)
    ``active`` (``[N]``: the unclipped term is the minimum, so the sample has a policy gradient) and
    ``value_frozen`` (``[N]``: the clipped value error is the larger and constant, so the sample has
    no value gradient); grads shaped like ``joint``.
    """
    w = batch["weights"]
    c = w / max(w.sum(), 1.0)  # each sample's share of a weighted mean
    adv = batch["advantages"]
    policy, value_layers = joint["policy"], joint["value"]

    dist = policy_forward(kind, policy, batch["obs"], policy_activation)
    ratio = np.exp(log_prob(kind, dist, batch["actions"]) - batch["log_probs"])
    if clip_eps > 0:
        clipped_ratio = np.clip(ratio, 1.0 - clip_eps, 1.0 + clip_eps)
        surrogate = np.minimum(ratio * adv, clipped_ratio * adv)
        # Inside the clip range both terms are r A; outside, the unclipped one carries the gradient
        # only where it is the smaller.
        active = ratio * adv <= clipped_ratio * adv
        clip_fraction = np.sum(c * (np.abs(ratio - 1.0) > clip_eps))
    else:
        surrogate, active, clip_fraction = ratio * adv, np.ones_like(ratio, bool), 0.0
    policy_loss = -np.sum(c * surrogate)
    ent = entropy(kind, dist)

    # d policy_loss / d log pi(a_i|s_i) = -c_i A_i r_i on active samples (d r / d log pi = r).
    d_log_prob = -c * adv * ratio * active
    if kind == "gaussian":
        mean, log_std = dist["mean"], dist["log_std"]
        var = np.exp(2.0 * log_std)
        z2 = (batch["actions"] - mean) ** 2 / var
        upstream = {
            "mean": d_log_prob[:, None] * (batch["actions"] - mean) / var,  # d log pi / d mean
            # d log pi / d log_std = z^2 - 1; d H / d log_std = 1 per axis.
            "log_std": d_log_prob[:, None] * (z2 - 1.0) - entropy_coef * c[:, None] * np.ones_like(mean),
        }
    else:
        probs = special.softmax(dist["logits"], axis=-1)
        log_probs_all = special.log_softmax(dist["logits"], axis=-1)
        onehot = np.eye(probs.shape[-1])[batch["actions"]]
        d_entropy = -probs * (log_probs_all + ent[:, None])  # d H / d logits
        upstream = {"logits": d_log_prob[:, None] * (onehot - probs) - entropy_coef * c[:, None] * d_entropy}
    policy_grads = policy_backward(kind, policy, dist, upstream, policy_activation)

    values, value_inputs = mlp_forward(value_layers, batch["obs"], value_activation)
    values = values[:, 0]
    targets = batch["value_targets"]
    err = (values - targets) ** 2
    d_values = 2.0 * (values - targets)
    value_frozen = np.zeros_like(values, bool)
    if value_clip_eps > 0:
        values_clipped = old_values + np.clip(values - old_values, -value_clip_eps, value_clip_eps)
        err_clipped = (values_clipped - targets) ** 2
        inside = np.abs(values - old_values) < value_clip_eps
        d_values = np.where(err >= err_clipped, d_values, 2.0 * (values_clipped - targets) * inside)
        value_frozen = (err < err_clipped) & ~inside
        err = np.maximum(err, err_clipped)
    value_loss = np.sum(c * err)
    value_grads = mlp_backward(value_layers, value_inputs, (value_coef * c * d_values)[:, None], value_activation)

    mean_entropy = np.sum(c * ent)
    total = policy_loss + value_coef * value_loss - entropy_coef * mean_entropy
    diagnostics = {
        "policy_loss": policy_loss,
        "value_loss": value_loss,
        "entropy": mean_entropy,
        "approx_kl": np.sum(c * ((ratio - 1.0) - np.log(ratio))),
        "clip_fraction": clip_fraction,
        "active": active,
        "value_frozen": value_frozen,
    }
    return total, diagnostics, {"policy": policy_grads, "value": value_grads}


def gaussian_fisher(params: Any, obs: np.ndarray, weights: np.ndarray, activation: str) -> np.ndarray:
    """The dense ``[P, P]`` Fisher matrix (parameters in pytree order) of a Gaussian policy with an
    MLP mean and a global ``log_std``, averaged over the states ``obs [N, d]`` with ``weights [N]``:
    ``sum_i c_i J_i' diag(1/sigma^2, 2) J_i``, ``J_i`` the Jacobian of ``(mean, log_std)`` at state
    ``i`` (``diag(1/sigma^2, 2)`` is the Fisher matrix of ``N(mu, sigma^2)`` in ``(mu, log sigma)``)."""
    dist = policy_forward("gaussian", params, obs, activation)
    n, action_size = dist["mean"].shape
    c = weights / weights.sum()
    fisher = 0.0
    for axis in range(action_size):
        upstream = np.zeros((n, action_size))
        upstream[:, axis] = 1.0
        mean_jac = flat(
            {
                "log_std": np.zeros((n, action_size)),
                "mean": mlp_backward(params["mean"], dist["inputs"], upstream, activation, per_sample=True),
            },
            per_sample=True,
        )
        unit = np.zeros(action_size)
        unit[axis] = 1.0
        log_std_jac = flat({"log_std": unit, "mean": jax.tree.map(np.zeros_like, params["mean"])})
        inv_var = np.exp(-2.0 * params["log_std"][axis])
        fisher = fisher + inv_var * (mean_jac.T * c) @ mean_jac + 2.0 * np.outer(log_std_jac, log_std_jac)
    return fisher


def gae(
    rewards: np.ndarray,
    values: np.ndarray,
    next_values: np.ndarray,
    terminated: np.ndarray,
    truncated: np.ndarray,
    gamma: float,
    lam: float,
) -> np.ndarray:
    """``[T, B]`` GAE advantages by a backward loop: ``delta_t = r_t + gamma (1 - term_t)
    V(next_obs_t) - V(obs_t)``, ``A_t = delta_t + gamma lam A_{t+1}`` within an episode (a done
    step starts the sum afresh), the last row bootstrapping through ``next_values``."""
    steps, envs = rewards.shape
    adv = np.zeros((steps, envs))
    for b in range(envs):
        running = 0.0
        for t in reversed(range(steps)):
            if terminated[t, b] or truncated[t, b]:
                running = 0.0
            bootstrap = 0.0 if terminated[t, b] else gamma * next_values[t, b]
            running = rewards[t, b] + bootstrap - values[t, b] + gamma * lam * running
            adv[t, b] = running
    return adv


def normalized_rewards(
    rewards: np.ndarray, ended: np.ndarray, valid: np.ndarray, gamma: float, clip: float = 10.0
) -> np.ndarray:
    """Stable-Baselines3's ``VecNormalize`` reward path, one step of ``B`` envs at a time, from
    ``rewards``, ``ended`` and ``valid`` ``[T, B]``: each env's discounted return ``g = gamma g + r``,
    every valid ``g`` so far kept, the step's reward divided by ``sqrt(var(all of them) + 1e-8)``
    and clipped, then ``g`` reset where the episode ended. Returns ``[T, B]`` float64."""
    g = np.zeros(rewards.shape[1])
    seen: list[float] = []
    out = np.zeros(rewards.shape)
    for t in range(rewards.shape[0]):
        g = gamma * g + rewards[t]
        seen.extend(g[valid[t] > 0])
        out[t] = np.clip(rewards[t] / np.sqrt(np.var(seen) + 1e-8), -clip, clip)
        g = np.where(ended[t], 0.0, g)
    return out
