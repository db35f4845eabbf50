"""Stochastic policies and the value function.

A policy is a frozen (hashable) dataclass holding only configuration, so it can be a static field
of a ``TrainState`` or a static argument of ``jit``; its parameters are a separate pytree. Every
policy has the same methods:

* ``init(key, obs_size) -> params``
* ``dist(params, obs [..., obs_dim]) -> dist`` (a pytree of ``jaxpg.distributions``)
* ``sample(params, obs, key) -> (action, log_prob)`` -- the rollout's ``act_fn``
* ``log_prob(params, obs, action)``, ``entropy(params, obs)``, ``kl(params_old, params_new, obs)``,
  ``mode(params, obs)``, all ``[...]`` (or the action shape for ``mode``)
* ``dist_log_prob``, ``dist_entropy``, ``dist_kl``, ``dist_mode``, ``dist_sample`` and
  ``fisher_metric`` on distribution pytrees, for losses that reuse one forward pass
* ``discrete``: actions are int32 indices rather than float vectors.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import jax
import jax.numpy as jnp

from jaxpg import distributions as D
from jaxpg.networks import MLP, ConvTorso, activation_fn

Params = Any


class Policy:
    """Methods shared by all policies, written in terms of ``dist`` and the ``dist_*`` functions."""

    discrete: ClassVar[bool]

    def init(self, key: jax.Array, obs_size: int) -> Params:
        raise NotImplementedError

    def dist(self, params: Params, obs: jax.Array) -> D.Dist:
        raise NotImplementedError

    def dist_sample(self, dist: D.Dist, key: jax.Array) -> jax.Array:
        raise NotImplementedError

    def dist_log_prob(self, dist: D.Dist, action: jax.Array) -> jax.Array:
        raise NotImplementedError

    def dist_entropy(self, dist: D.Dist) -> jax.Array:
        raise NotImplementedError

    def dist_kl(self, dist_old: D.Dist, dist_new: D.Dist) -> jax.Array:
        raise NotImplementedError

    def dist_mode(self, dist: D.Dist) -> jax.Array:
        raise NotImplementedError

    def fisher_metric(self, dist: D.Dist, tangent: D.Dist) -> D.Dist:
        raise NotImplementedError

    def sample(self, params: Params, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        """``obs: [..., obs_dim] -> (action [..., A] or int32 [...], log_prob [...])``."""
        dist = self.dist(params, obs)
        action = self.dist_sample(dist, key)
        return action, self.dist_log_prob(dist, action)

    def log_prob(self, params: Params, obs: jax.Array, action: jax.Array) -> jax.Array:
        """``log pi(action | obs)``: ``[...]``."""
        return self.dist_log_prob(self.dist(params, obs), action)

    def entropy(self, params: Params, obs: jax.Array) -> jax.Array:
        """Entropy of ``pi(. | obs)``: ``[...]``."""
        return self.dist_entropy(self.dist(params, obs))

    def kl(self, params_old: Params, params_new: Params, obs: jax.Array) -> jax.Array:
        """Per-state ``KL(pi_old(. | obs) || pi_new(. | obs))``: ``[...]``."""
        return self.dist_kl(self.dist(params_old, obs), self.dist(params_new, obs))

    def mode(self, params: Params, obs: jax.Array) -> jax.Array:
        """The deterministic ("mean") policy: the mean action, or the argmax for discrete actions."""
        return self.dist_mode(self.dist(params, obs))


class _GaussianMixin(Policy):
    """Distribution functions of a diagonal Gaussian policy."""

    discrete: ClassVar[bool] = False

    def dist_sample(self, dist: D.Dist, key: jax.Array) -> jax.Array:
        return D.gaussian_sample(dist, key)

    def dist_log_prob(self, dist: D.Dist, action: jax.Array) -> jax.Array:
        return D.gaussian_log_prob(dist, action)

    def dist_entropy(self, dist: D.Dist) -> jax.Array:
        return D.gaussian_entropy(dist)

    def dist_kl(self, dist_old: D.Dist, dist_new: D.Dist) -> jax.Array:
        return D.gaussian_kl(dist_old, dist_new)

    def dist_mode(self, dist: D.Dist) -> jax.Array:
        return D.gaussian_mode(dist)

    def fisher_metric(self, dist: D.Dist, tangent: D.Dist) -> D.Dist:
        return D.gaussian_fisher_metric(dist, tangent)


@dataclasses.dataclass(frozen=True)
class GaussianPolicy(_GaussianMixin):
    """``pi(a|s) = N(mu_theta(s), diag(exp(2 log_std)))`` with an MLP mean and a learned *global*
    log-std vector (LyceumAI's ``DiagGaussianPolicy``, mjrl's ``MLP`` policy, the Lightning VPG).

    Params: ``{"mean": MLP params, "log_std": [A]}``. ``dist`` broadcasts ``log_std`` to the
    mean's shape ``[..., A]`` so that every leaf of the distribution has the batch axes.
    """

    action_size: int
    hidden: tuple[int, ...] = (32, 32)
    activation: str = "tanh"
    kernel_init: str = "glorot_uniform"
    bias_init: str = "glorot_uniform"
    log_std_init: float = 0.0
    final_kernel_scale: float | None = None
    kernel_scale: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "hidden", tuple(self.hidden))

    @property
    def mean_net(self) -> MLP:
        """The network ``obs [..., obs_dim] -> mean [..., A]``."""
        return MLP(
            (*self.hidden, self.action_size),
            activation=self.activation,
            kernel_init=self.kernel_init,
            bias_init=self.bias_init,
            kernel_scale=self.kernel_scale,
            final_kernel_scale=self.final_kernel_scale,
        )

    def init(self, key: jax.Array, obs_size: int) -> Params:
        """``{"mean": MLP params, "log_std": full([A], log_std_init)}``."""
        return {
            "mean": self.mean_net.init(key, obs_size),
            "log_std": jnp.full((self.action_size,), self.log_std_init, jnp.float32),
        }

    def dist(self, params: Params, obs: jax.Array) -> D.Dist:
        """``obs [..., obs_dim] -> {"mean": [..., A], "log_std": [..., A]}``."""
        mean = self.mean_net.apply(params["mean"], obs)
        return {"mean": mean, "log_std": jnp.broadcast_to(params["log_std"], mean.shape)}


@dataclasses.dataclass(frozen=True)
class StateStdGaussianPolicy(_GaussianMixin):
    """Gaussian policy whose std depends on the state (Gymnasium's REINFORCE tutorial):
    a shared trunk ``obs -> hidden`` (activation after every layer), then linear heads
    ``mean = h W_mu + b_mu`` and ``std = softplus(h W_s + b_s) + min_std``.

    Params: ``{"trunk": MLP params ([] if hidden is empty), "mean": [layer], "std": [layer]}``.
    """

    action_size: int
    hidden: tuple[int, ...] = (16, 32)
    activation: str = "tanh"
    min_std: float = 1e-6
    kernel_init: str = "glorot_uniform"
    bias_init: str = "glorot_uniform"
    final_kernel_scale: float | None = None
    kernel_scale: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "hidden", tuple(self.hidden))

    def _net(self, sizes: tuple[int, ...], final_scale: float | None) -> MLP:
        return MLP(
            sizes,
            activation=self.activation,
            kernel_init=self.kernel_init,
            bias_init=self.bias_init,
            kernel_scale=self.kernel_scale,
            final_kernel_scale=final_scale,
        )

    def init(self, key: jax.Array, obs_size: int) -> Params:
        k_trunk, k_mean, k_std = jax.random.split(key, 3)
        trunk = self._net(self.hidden, None).init(k_trunk, obs_size) if self.hidden else []
        features = self.hidden[-1] if self.hidden else obs_size
        head = self._net((self.action_size,), self.final_kernel_scale)
        return {"trunk": trunk, "mean": head.init(k_mean, features), "std": head.init(k_std, features)}

    def dist(self, params: Params, obs: jax.Array) -> D.Dist:
        """``obs [..., obs_dim] -> {"mean": [..., A], "log_std": log(softplus(.) + min_std) [..., A]}``."""
        h = jnp.asarray(obs, jnp.float32)
        if self.hidden:
            h = activation_fn(self.activation)(self._net(self.hidden, None).apply(params["trunk"], h))
        head = self._net((self.action_size,), self.final_kernel_scale)
        mean = head.apply(params["mean"], h)
        std = jax.nn.softplus(head.apply(params["std"], h)) + self.min_std
        return {"mean": mean, "log_std": jnp.log(std)}


@dataclasses.dataclass(frozen=True)
class CategoricalPolicy(Policy):
    """``pi(a|s) = softmax(f_theta(s))_a`` with an MLP ``f`` (Kokoyi's CartPole policy,
    ``4 -> 128 (ReLU) -> 2``). Actions are int32 indices in ``[0, num_actions)``.

    With ``conv`` (a ``ConvTorso``, for image observations), ``f`` is the MLP after the torso.

    Params: MLP params, or ``{"conv": ConvTorso params, "mlp": MLP params}`` with ``conv``.
    ``dist`` returns ``{"logits": [..., K]}``.
    """

    discrete: ClassVar[bool] = True

    num_actions: int
    hidden: tuple[int, ...] = (128,)
    activation: str = "relu"
    kernel_init: str = "glorot_uniform"
    bias_init: str = "glorot_uniform"
    final_kernel_scale: float | None = None
    kernel_scale: float = 1.0
    conv: ConvTorso | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "hidden", tuple(self.hidden))

    @property
    def action_size(self) -> int:
        """Number of actions (the name continuous policies use)."""
        return self.num_actions

    @property
    def logits_net(self) -> MLP:
        """The network ``obs [..., obs_dim] -> logits [..., K]``."""
        return MLP(
            (*self.hidden, self.num_actions),
            activation=self.activation,
            kernel_init=self.kernel_init,
            bias_init=self.bias_init,
            kernel_scale=self.kernel_scale,
            final_kernel_scale=self.final_kernel_scale,
        )

    def init(self, key: jax.Array, obs_size: int) -> Params:
        return _init_with_torso(self.conv, self.logits_net, key, obs_size)

    def dist(self, params: Params, obs: jax.Array) -> D.Dist:
        """``obs [..., obs_dim] -> {"logits": [..., K]}``."""
        return {"logits": _apply_with_torso(self.conv, self.logits_net, params, obs)}

    def dist_sample(self, dist: D.Dist, key: jax.Array) -> jax.Array:
        return D.categorical_sample(dist, key)

    def dist_log_prob(self, dist: D.Dist, action: jax.Array) -> jax.Array:
        return D.categorical_log_prob(dist, action)

    def dist_entropy(self, dist: D.Dist) -> jax.Array:
        return D.categorical_entropy(dist)

    def dist_kl(self, dist_old: D.Dist, dist_new: D.Dist) -> jax.Array:
        return D.categorical_kl(dist_old, dist_new)

    def dist_mode(self, dist: D.Dist) -> jax.Array:
        return D.categorical_mode(dist)

    def fisher_metric(self, dist: D.Dist, tangent: D.Dist) -> D.Dist:
        return D.categorical_fisher_metric(dist, tangent)


@dataclasses.dataclass(frozen=True)
class ValueFunction:
    """State-value baseline ``V_phi(s)``: an MLP ``obs -> hidden -> 1`` with the last axis dropped
    (LyceumAI: ``obs -> 128 -> 128 -> 1``, ReLU, Glorot-uniform); with ``conv``, the MLP follows
    a ``ConvTorso`` (params ``{"conv": ..., "mlp": ...}``, as ``CategoricalPolicy``'s).
    """

    hidden: tuple[int, ...] = (128, 128)
    activation: str = "relu"
    kernel_init: str = "glorot_uniform"
    bias_init: str = "glorot_uniform"
    final_kernel_scale: float | None = None
    kernel_scale: float = 1.0
    conv: ConvTorso | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "hidden", tuple(self.hidden))

    @property
    def net(self) -> MLP:
        """The network ``obs [..., obs_dim] -> [..., 1]``."""
        return MLP(
            (*self.hidden, 1),
            activation=self.activation,
            kernel_init=self.kernel_init,
            bias_init=self.bias_init,
            kernel_scale=self.kernel_scale,
            final_kernel_scale=self.final_kernel_scale,
        )

    def init(self, key: jax.Array, obs_size: int) -> Params:
        return _init_with_torso(self.conv, self.net, key, obs_size)

    def apply(self, params: Params, obs: jax.Array) -> jax.Array:
        """``obs [..., obs_dim] -> V(obs) [...]``."""
        return _apply_with_torso(self.conv, self.net, params, obs)[..., 0]


def _init_with_torso(conv: ConvTorso | None, mlp: MLP, key: jax.Array, obs_size: int) -> Params:
    """``mlp``'s params for ``[..., obs_size]`` inputs, or with ``conv``
    ``{"conv": torso params, "mlp": params for the torso's features}``."""
    if conv is None:
        return mlp.init(key, obs_size)
    if conv.in_size != obs_size:
        raise ValueError(f"the conv torso reads {conv.image_shape} images ({conv.in_size} values), not {obs_size}")
    k_conv, k_mlp = jax.random.split(key)
    return {"conv": conv.init(k_conv), "mlp": mlp.init(k_mlp, conv.out_size)}


def _apply_with_torso(conv: ConvTorso | None, mlp: MLP, params: Params, obs: jax.Array) -> jax.Array:
    """``obs [..., obs_dim] -> [..., out]`` through the torso (if any), then ``mlp``."""
    if conv is None:
        return mlp.apply(params, obs)
    return mlp.apply(params["mlp"], conv.apply(params["conv"], obs))


POLICIES: dict[str, type[Policy]] = {
    "gaussian": GaussianPolicy,
    "state_std_gaussian": StateStdGaussianPolicy,
    "categorical": CategoricalPolicy,
}


def make_policy(name: str, action_size: int, discrete: bool, **kwargs: Any) -> Policy:
    """The policy ``name`` ("gaussian", "state_std_gaussian", "categorical") for ``action_size``
    actions (the number of choices when ``discrete``); ``kwargs`` go to its constructor.
    """
    if name not in POLICIES:
        raise ValueError(f"unknown policy {name!r}; expected one of {', '.join(POLICIES)}")
    cls = POLICIES[name]
    if cls.discrete != discrete:
        kind = "discrete" if discrete else "continuous"
        raise ValueError(f"policy {name!r} does not fit {kind} actions")
    if cls is CategoricalPolicy:
        return CategoricalPolicy(num_actions=action_size, **kwargs)
    return cls(action_size=action_size, **kwargs)
