"""Placing a ``TrainState`` on a device mesh: its env batch split over the ``"envs"`` axis."""

from __future__ import annotations

from typing import Any

import jax
from jax.sharding import NamedSharding

from jaxpg import mesh as mesh_lib
from jaxpg.algos.core.sampling import env_batch_mask
from jaxpg.algos.core.state import sampler_env


def shard_state(ts: Any, vmap_seeds: bool, mesh: Any = None) -> Any:
    """``ts`` placed on ``mesh`` (default: ``jaxpg.mesh.env_mesh()``, every device of every
    process): the env axis of ``ts.env_state`` split over the ``"envs"`` axis (after the seed axis
    with ``vmap_seeds``), everything else replicated, including MuJoCo Warp's per-batch buffers
    (``core.env_batch_mask``). Every process passes the same ``ts``; each places its share."""
    mesh = mesh_lib.env_mesh() if mesh is None else mesh
    lead = 1 if vmap_seeds else 0
    mask = env_batch_mask(sampler_env(ts.env, ts.config), ts.env_state, leading=lead)
    shardings = jax.tree.map(lambda batched: NamedSharding(mesh, mesh_lib.batch_spec(batched, lead)), mask)
    env_state = mesh_lib.put_global(ts.env_state, shardings)
    rest = mesh_lib.replicated(ts.replace(env_state=()), mesh)
    return rest.replace(env_state=env_state)
