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

``ConvTorso`` is the convolutional front of a network on image observations (the Atari networks of
Mnih et al.): flat observations are reshaped to images, convolved, and flattened again, so the
MLP that follows sees ``[..., features]`` like any other input. Its kernels are initialised by the
same schemes, on the ``[kernel * kernel * in_channels, out_channels]`` matrix of each layer.
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


# The convolutional torsos of the Atari literature, as (out_channels, kernel, stride) per layer, each
# followed by a ReLU: Mnih et al. (2013)'s two layers, and the "Nature" network of Mnih et al.
# (2015) that A2C, PPO and most Atari baselines use.
CONV_TORSOS: dict[str, tuple[tuple[int, int, int], ...]] = {
    "none": (),
    "mnih2013": ((16, 8, 4), (32, 4, 2)),
    "nature": ((32, 8, 4), (64, 4, 2), (64, 3, 1)),
}


@dataclasses.dataclass(frozen=True)
class ConvTorso:
    """Convolutions ``x [..., H * W * C] -> [..., features]``: the flat input is read as an
    ``[H, W, C]`` image (row-major, channels last), each layer is a VALID convolution with a stride,
    then a ReLU, and the last feature map is flattened. Hashable, like ``MLP``.

    Attributes:
      image_shape: ``(H, W, C)`` of one observation.
      layers: ``(out_channels, kernel, stride)`` per layer (see ``CONV_TORSOS``).
      kernel_init, kernel_scale: as ``MLP``'s, on each kernel seen as a
        ``[kernel * kernel * in_channels, out_channels]`` matrix; biases start at zero.
    """

    image_shape: tuple[int, int, int]
    layers: tuple[tuple[int, int, int], ...]
    kernel_init: str = "orthogonal"
    kernel_scale: float = math.sqrt(2.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "image_shape", tuple(int(n) for n in self.image_shape))
        object.__setattr__(self, "layers", tuple(tuple(int(n) for n in layer) for layer in self.layers))
        if len(self.image_shape) != 3 or min(self.image_shape) < 1:
            raise ValueError(f"image_shape must be (height, width, channels), got {self.image_shape}")
        if not self.layers or any(len(layer) != 3 or min(layer) < 1 for layer in self.layers):
            raise ValueError(f"layers must be non-empty (out_channels, kernel, stride) triples, got {self.layers}")
        if self.kernel_init not in KERNEL_INITS:
            raise ValueError(f"unknown kernel_init {self.kernel_init!r}; expected one of {', '.join(KERNEL_INITS)}")
        self.feature_map_shapes()  # raises for an image too small for the layers

    def feature_map_shapes(self) -> list[tuple[int, int, int]]:
        """``(height, width, channels)`` after each layer."""
        h, w, _ = self.image_shape
        shapes = []
        for channels, kernel, stride in self.layers:
            h, w = (h - kernel) // stride + 1, (w - kernel) // stride + 1
            if h < 1 or w < 1:
                raise ValueError(f"a {self.image_shape[0]}x{self.image_shape[1]} image is too small for {self.layers}")
            shapes.append((h, w, channels))
        return shapes

    @property
    def in_size(self) -> int:
        """Length of a flat observation, ``H * W * C``."""
        return math.prod(self.image_shape)

    @property
    def out_size(self) -> int:
        """Length of the flattened last feature map."""
        return math.prod(self.feature_map_shapes()[-1])

    def init(self, key: jax.Array) -> Params:
        """A list of ``{"w": [kernel, kernel, in_channels, out_channels], "b": [out_channels]}``."""
        params = []
        in_channels = self.image_shape[2]
        for layer_key, (channels, kernel, _) in zip(jax.random.split(key, len(self.layers)), self.layers, strict=True):
            k_unif, k_normal = jax.random.split(layer_key)
            fan_in = kernel * kernel * in_channels
            unif = jax.random.uniform(k_unif, (fan_in, channels), jnp.float32, -1.0, 1.0)
            normal = jax.random.normal(k_normal, (fan_in * channels,), jnp.float32)
            w = _kernel(unif, normal, self.kernel_init, self.kernel_scale)
            params.append({"w": w.reshape(kernel, kernel, in_channels, channels), "b": jnp.zeros((channels,))})
            in_channels = channels
        return params

    def apply(self, params: Params, x: jax.Array) -> jax.Array:
        """``x: [..., H * W * C] -> [..., out_size]``, a ReLU after every layer."""
        batch_shape = x.shape[:-1]
        h = jnp.reshape(jnp.asarray(x, jnp.float32), (-1, *self.image_shape))
        for layer, (_, _, stride) in zip(params, self.layers, strict=True):
            h = jax.lax.conv_general_dilated(
                h, layer["w"], (stride, stride), "VALID", dimension_numbers=("NHWC", "HWIO", "NHWC")
            )
            h = jax.nn.relu(h + layer["b"])
        return jnp.reshape(h, (*batch_shape, self.out_size))
