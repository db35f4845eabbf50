"""The device mesh the env batch is split over, used inside jit: pure of any process launch.

The env batch is the one axis jaxpg splits: a 1-D device ``Mesh`` with the axis ``"envs"``
(``ENV_AXIS``) spans every device of every process, and ``jaxpg.algos.core.sample`` /
``evaluate`` step each device's own slice of the envs under ``jax.shard_map``. The sampler learns
about the mesh from JAX's mesh context (``jax.sharding.get_abstract_mesh()``), which
``on_mesh(update, mesh)`` sets while ``update`` is traced (``jax.set_mesh(mesh)`` around a call
works as well); with no mesh in context, or one without the ``"envs"`` axis, sampling runs on one
device as it always did. The learning side stays under jit's automatic partitioning (GSPMD),
which makes every reduction over the batch global.

Arrays are placed on the global mesh from identical host values (``put_global``) and fetched back
with ``host_copy``; ``jaxpg.algos.core.shard_state`` places a whole ``TrainState``. Joining several
processes is the host's business: ``jaxpg.run.host.processes``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import jax
import numpy as np
from jax.experimental import multihost_utils
from jax.sharding import AbstractMesh, AxisType, Mesh, NamedSharding, PartitionSpec

ENV_AXIS = "envs"


def env_mesh(devices: Any = None) -> Mesh:
    """A 1-D mesh with the axis ``ENV_AXIS`` over ``devices`` (default: ``jax.devices()``, i.e.
    every device of every process). Its axis is ``Auto``: outside ``shard_map`` jit partitions."""
    devices = jax.devices() if devices is None else list(devices)
    if len(devices) > 1:
        use_gspmd_partitioner()
    return Mesh(np.array(devices), (ENV_AXIS,), axis_types=(AxisType.Auto,))


def use_gspmd_partitioner() -> None:
    """Partition sharded programs with GSPMD instead of Shardy (JAX's default since 0.7).

    With JAX 0.11.2 on GPUs, XLA's compiler crashed (segmentation fault in the ``shardy-xla`` pass)
    on jaxpg's rollout under ``shard_map`` over two GPUs, with both MJX implementations; with GSPMD
    the same program compiles and scales (BENCHMARKS.md, "Several GPUs"). A multi-device ``env_mesh``
    calls this, on every backend, so that the CPU tests run the partitioner the GPUs use.
    """
    if getattr(jax.config, "jax_use_shardy_partitioner", False):
        jax.config.update("jax_use_shardy_partitioner", False)


def context_env_shards() -> int:
    """How many slices the env batch is split into by the mesh in context (1: none).

    Read while tracing: the abstract mesh that ``on_mesh`` or ``jax.set_mesh`` put in context, if
    it has the ``ENV_AXIS`` axis.
    """
    mesh = jax.sharding.get_abstract_mesh()
    if mesh.empty or ENV_AXIS not in mesh.axis_names:
        return 1
    return int(mesh.shape[ENV_AXIS])


def check_divisible(num_envs: int, shards: int, what: str = "num_envs") -> None:
    """``ValueError`` (one line) unless ``num_envs`` splits evenly over ``shards`` devices."""
    if num_envs % shards:
        raise ValueError(
            f"{what} {num_envs} is not divisible by the {shards} devices the env batch is split over "
            "(use a multiple of the device count)"
        )


@functools.lru_cache(maxsize=64)
def on_mesh(update: Callable[..., Any], mesh: Mesh | AbstractMesh) -> Callable[..., Any]:
    """``update`` traced with ``mesh`` in context, so that its sampling splits the env batch.

    The result is a plain function (``jit``, ``vmap`` and ``lax.scan`` it like ``update``), cached
    per ``(update, mesh)`` so that ``jaxpg.train``'s compiled blocks are reused. Only the tracing of
    ``update`` sees the mesh: jitted host-side code elsewhere (videos, checkpoints) is unaffected,
    which ``jax.set_mesh`` around the training loop would not guarantee. The state should already
    live on ``mesh`` (``shard_state``).
    """
    abstract = mesh.abstract_mesh if isinstance(mesh, Mesh) else mesh

    @functools.wraps(update)
    def update_on_mesh(*args: Any, **kwargs: Any) -> Any:
        with jax.sharding.use_abstract_mesh(abstract):
            return update(*args, **kwargs)

    return update_on_mesh


def batch_spec(batched: bool, leading: int = 0) -> PartitionSpec:
    """``PartitionSpec`` of an env-state leaf: its env axis (after ``leading`` unsplit axes, e.g.
    the seed axis) on ``ENV_AXIS`` when ``batched``, else replicated."""
    return PartitionSpec(*([None] * leading), ENV_AXIS) if batched else PartitionSpec()


# --------------------------------------------------------------------------- placing and fetching


def put_global(tree: Any, shardings: Any) -> Any:
    """Place ``tree`` (host values, identical on every process) with ``shardings`` (a matching
    tree of ``Sharding``s, which may span several processes). Each process supplies the slices
    its own devices hold (``jax.make_array_from_callback``); with one process this is a
    ``device_put``."""

    def put(x: Any, sharding: jax.sharding.Sharding) -> jax.Array:
        host = np.asarray(x)
        return jax.make_array_from_callback(host.shape, sharding, lambda index: host[index])

    return jax.tree.map(put, host_copy(tree), shardings)


def host_copy(tree: Any) -> Any:
    """NumPy copy of ``tree`` on every process. Arrays split over several processes are
    gathered (a collective: every process must call this with the same tree); replicated and
    local arrays are read locally."""

    def fetch(x: Any) -> np.ndarray:
        if isinstance(x, jax.Array) and not x.is_fully_addressable and not x.is_fully_replicated:
            return np.asarray(multihost_utils.process_allgather(x, tiled=True))
        return np.asarray(jax.device_get(x))

    return jax.tree.map(fetch, tree)


def replicated(tree: Any, mesh: Mesh) -> Any:
    """``tree`` replicated on every device of ``mesh`` (``put_global`` with ``PartitionSpec()``)."""
    sharding = NamedSharding(mesh, PartitionSpec())
    return put_global(tree, jax.tree.map(lambda _: sharding, tree))
