"""What a released Brax needs from JAX that JAX no longer has, supplied only where asked.

Brax 0.14.2's trainers (PPO, SAC, APG and ``brax.training.pmap.bcast_local_devices``) place their
training state with ``jax.device_put_replicated(tree, devices)``, which JAX removed in 0.10: they
fail with ``AttributeError`` before their first step. ``replicated_on_devices`` does the same job
with JAX's stable API, and ``brax_jax_shim()`` lends it to ``jax`` under that name for the length of
a ``with`` block only, so that nothing changes for code outside it:

    with brax_jax_shim():
        make_policy, params, metrics = brax.training.agents.ppo.train.train(environment=env, ...)

Nothing in jaxpg enters the block on import; where JAX still has the function it is left alone.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

REMOVED_NAME = "device_put_replicated"


def replicated_on_devices(tree: Any, devices: Sequence[Any]) -> Any:
    """Every leaf ``[...]`` of ``tree`` stacked ``len(devices)`` times, ``[len(devices), ...]``, with
    copy ``i`` on ``devices[i]``: what ``jax.device_put_replicated`` returned, the layout that
    ``jax.pmap`` takes for an argument replicated over those devices."""
    devices = list(devices)
    if not devices:
        raise ValueError("replicated_on_devices needs at least one device")
    mesh = jax.sharding.Mesh(np.array(devices), ("replica",))
    sharding = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("replica"))

    def put(leaf: Any) -> jax.Array:
        leaf = jnp.asarray(leaf)
        return jax.device_put(jnp.broadcast_to(leaf[None], (len(devices), *leaf.shape)), sharding)

    return jax.tree.map(put, tree)


@contextlib.contextmanager
def brax_jax_shim() -> Iterator[None]:
    """Inside the block, ``jax.device_put_replicated`` is ``replicated_on_devices`` (where JAX
    lacks it); on leaving, ``jax`` is as it was. Not thread-safe: the name is set on the module."""
    if hasattr(jax, REMOVED_NAME):
        yield
        return
    setattr(jax, REMOVED_NAME, replicated_on_devices)
    try:
        yield
    finally:
        delattr(jax, REMOVED_NAME)
