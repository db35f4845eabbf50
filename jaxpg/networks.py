"""Multi-layer perceptrons as a frozen config plus two pure functions, ``init`` and ``apply``.

Parameters are a plain list of ``{"w": [in, out], "b": [out]}`` dicts, one per layer, so that
policies, value functions, the Fisher-vector product and checkpoints all see the same simple
pytree. The initialisers cover the schemes of the systems jaxpg reproduces:

* ``"glorot_uniform"`` (Glorot & Bengio, 2010): ``W ~ U(-sqrt(6/(in+out)), +sqrt(6/(in+out)))``.
  As a *bias* initialiser it follows Flux (LyceumAI), which treats a length-``n`` vector as a
  ``[n, 1]`` matrix: ``b ~ U(-sqrt(6/(1+n)), +sqrt(6/(1+n)))``.
* ``"pytorch"`` (``torch.nn.Linear``'s default): ``W, b ~ U(-1/sqrt(in), +1/sqrt(in))``.
* ``"orthogonal"`` (Saxe et al., 2014), the PPO/Brax convention: ``W`` a (semi-)orthogonal matrix
  times ``kernel_scale``; as a bias initialiser it means zeros.
* ``"zeros"``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import jax
import jax.numpy as jnp

Params = list[dict[str, jax.Array]]

ACTIVATIONS: dict[str, Callable[[jax.Array], jax.Array]] = {
    "tanh": jnp.tanh,
    "relu": jax.nn.relu,
    "elu": jax.nn.elu,
    # The exact (erf) form, as torch.nn.GELU's default.
    "gelu": lambda x: jax.nn.gelu(x, approximate=False),
    "swish": jax.nn.swish,
    "identity": lambda x: x,
}
KERNEL_INITS = ("glorot_uniform", "pytorch", "orthogonal", "zeros")
BIAS_INITS = ("glorot_uniform", "pytorch", "orthogonal", "zeros")


def activation_fn(name: str) -> Callable[[jax.Array], jax.Array]:
    """The elementwise activation called ``name`` (one of ``ACTIVATIONS``)."""
    if name not in ACTIVATIONS:
        raise ValueError(f"unknown activation {name!r}; expected one of {', '.join(ACTIVATIONS)}")
    return ACTIVATIONS[name]


def _kernel(unif: jax.Array, normal: jax.Array | None, scheme: str, scale: float) -> jax.Array:
    """A ``[in, out]`` kernel by ``scheme`` from noise ``unif ~ U(-1, 1)`` / ``normal ~ N(0, 1)``.

    For ``"orthogonal"`` the scale is the gain of the orthogonal matrix (Saxe et al., 2014): the
    Q factor of a Gaussian matrix, signs fixed by ``diag(R)`` so that it is Haar-distributed.
    """
    n_in, n_out = unif.shape
    if scheme == "glorot_uniform":
        w = unif * math.sqrt(6.0 / (n_in + n_out))
    elif scheme == "pytorch":
        w = unif / math.sqrt(n_in)
    elif scheme == "orthogonal":
        assert normal is not None
        tall = normal.reshape(max(n_in, n_out), min(n_in, n_out))
        q, r = jnp.linalg.qr(tall)
        q = q * jnp.sign(jnp.diagonal(r))
        w = q if n_in >= n_out else q.T
    else:  # zeros
        w = jnp.zeros_like(unif)
    return scale * w


def _bias(unif: jax.Array, n_in: int, scheme: str) -> jax.Array:
    """A ``[out]`` bias by ``scheme`` from noise ``unif ~ U(-1, 1)`` (see the module docstring)."""
    if scheme == "glorot_uniform":
        return unif * math.sqrt(6.0 / (1 + unif.shape[0]))
    if scheme == "pytorch":
        return unif / math.sqrt(n_in)
    return jnp.zeros_like(unif)  # zeros, orthogonal


@dataclasses.dataclass(frozen=True)
class MLP:
    """A fully connected network ``x -> act(x W_1 + b_1) -> ... -> x W_L + b_L``.

    Hashable (a frozen dataclass of tuples and strings), so it can be a static argument of ``jit``.

    Attributes:
      layer_sizes: the hidden sizes followed by the output size, e.g. ``(32, 32, act_dim)``.
      activation: after every layer but the last: tanh, relu, elu, gelu, swish or identity.
      kernel_init: ``"glorot_uniform"``, ``"pytorch"``, ``"orthogonal"`` or ``"zeros"``.
      bias_init: ``"glorot_uniform"`` (Flux's vector rule), ``"pytorch"``, ``"zeros"``, or
        ``"orthogonal"`` (which means zeros).
      kernel_scale: multiplies every kernel at initialisation (the gain for ``"orthogonal"``).
      final_kernel_scale: if set, the last layer's kernel *and bias* are multiplied by it instead
        (e.g. 0.01 for a policy head, so that the initial policy is close to its bias-free mean).
      dtype: parameter dtype; inputs are cast to it.
    """

    layer_sizes: tuple[int, ...]
    activation: str = "tanh"
    kernel_init: str = "glorot_uniform"
    bias_init: str = "glorot_uniform"
    kernel_scale: float = 1.0
    final_kernel_scale: float | None = None
    dtype: str = "float32"

    def __post_init__(self) -> None:
        object.__setattr__(self, "layer_sizes", tuple(int(n) for n in self.layer_sizes))
        if not self.layer_sizes or min(self.layer_sizes) < 1:
            raise ValueError(f"layer_sizes must be non-empty positive sizes, got {self.layer_sizes}")
        activation_fn(self.activation)
        if self.kernel_init not in KERNEL_INITS:
            raise ValueError(f"unknown kernel_init {self.kernel_init!r}; expected one of {', '.join(KERNEL_INITS)}")
        if self.bias_init not in BIAS_INITS:
            raise ValueError(f"unknown bias_init {self.bias_init!r}; expected one of {', '.join(BIAS_INITS)}")

    def init(self, key: jax.Array, in_size: int) -> Params:
        """Parameters for inputs ``[..., in_size]``: a list of ``{"w": [in, out], "b": [out]}``.

        Compiled as one program (called eagerly, the many small random draws would each compile).
        """
        return _jit_init(self, key, int(in_size))

    def _init(self, key: jax.Array, in_size: int) -> Params:
        sizes = (in_size, *self.layer_sizes)
        shapes = list(zip(sizes[:-1], sizes[1:], strict=True))
        # One draw for the whole network: each separate random call would add its own compile.
        k_unif, k_normal = jax.random.split(key)
        unif = jax.random.uniform(k_unif, (sum((i + 1) * o for i, o in shapes),), jnp.float32, -1.0, 1.0)
        normal = None
        if self.kernel_init == "orthogonal":
            normal = jax.random.normal(k_normal, (sum(i * o for i, o in shapes),), jnp.float32)
        params, u_at, n_at = [], 0, 0
        for idx, (n_in, n_out) in enumerate(shapes):
            last = idx == len(shapes) - 1
            u_w = unif[u_at : u_at + n_in * n_out].reshape(n_in, n_out)
            u_b = unif[u_at + n_in * n_out : u_at + (n_in + 1) * n_out]
            n_w = None if normal is None else normal[n_at : n_at + n_in * n_out]
            u_at, n_at = u_at + (n_in + 1) * n_out, n_at + n_in * n_out
            scale = self.final_kernel_scale if last and self.final_kernel_scale is not None else self.kernel_scale
            w = _kernel(u_w, n_w, self.kernel_init, scale)
            b = _bias(u_b, n_in, self.bias_init)
            if last and self.final_kernel_scale is not None:
                b = self.final_kernel_scale * b
            params.append({"w": w.astype(self.dtype), "b": b.astype(self.dtype)})
        return params

    def apply(self, params: Params, x: jax.Array) -> jax.Array:
        """``x: [..., in] -> [..., out]``; no activation after the last layer."""
        act = activation_fn(self.activation)
        h = jnp.asarray(x, self.dtype)
        for i, layer in enumerate(params):
            h = h @ layer["w"] + layer["b"]
            if i < len(params) - 1:
                h = act(h)
        return h


_jit_init = jax.jit(MLP._init, static_argnums=(0, 2))
