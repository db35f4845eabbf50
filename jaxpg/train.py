"""The training loop: many iterations per compiled call, host callbacks between calls.

``update`` (from any ``jaxpg.algos`` module) is ``lax.scan``-ned over ``block_size`` iterations in
one jitted program; after each block the host receives the block's metrics (``[block_size]``
arrays, or ``[block_size, num_seeds]`` when training several seeds) and calls the callbacks
(logging, checkpoints, progress bars). Several seeds train in one program by ``vmap``-ing ``init``
and ``update`` (``init_seeds`` / ``seeds=True``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxpg.algos.common import TrainState

UpdateFn = Callable[[TrainState], tuple[TrainState, dict[str, jax.Array]]]
Callback = Callable[[TrainState, dict[str, np.ndarray], int], None]


class TrainingDiverged(RuntimeError):
    """Raised when updates keep producing non-finite parameters or losses."""


def init_seeds(init: Callable[..., TrainState], seeds: Sequence[int], env: Any, config: Any) -> TrainState:
    """One ``TrainState`` per seed, stacked on a leading ``[num_seeds]`` axis (``vmap`` of ``init``)."""
    keys = jnp.stack([jax.random.PRNGKey(s) for s in seeds])
    return jax.vmap(lambda k: init(k, env, config))(keys)


def scan_updates(update: UpdateFn, train_state: TrainState, num_iterations: int) -> tuple[TrainState, dict]:
    """Pure: ``num_iterations`` updates as one ``lax.scan``; metrics stacked ``[num_iterations]``."""
    return jax.lax.scan(lambda ts, _: update(ts), train_state, None, length=num_iterations)


@functools.lru_cache(maxsize=32)
def compiled_block(update: UpdateFn, block_size: int, seeds: bool) -> Callable:
    """The jitted ``train_state -> (train_state, metrics)`` for one block (cached per update/size).

    With ``seeds`` the block is ``vmap``-ed over the leading seed axis and metrics come back as
    ``[block_size, num_seeds]``. The input state's buffers are donated.
    """
    step = jax.vmap(update) if seeds else update
    return jax.jit(functools.partial(scan_updates, step, num_iterations=block_size), donate_argnums=0)


@jax.jit
def _private_copy(tree: Any) -> Any:
    return jax.tree.map(jnp.copy, tree)


def default_iterations_per_call(train_state: TrainState, block_size: int) -> int:
    """1 for MuJoCo Warp tasks (see ``train``), else ``block_size``."""
    return 1 if getattr(train_state.env.unwrapped, "impl", None) == "warp" else block_size


def _chunk_sizes(total: int, per_call: int) -> list[int]:
    """``total`` iterations as calls of ``per_call`` (the last one shorter)."""
    return [min(per_call, total - start) for start in range(0, total, per_call)]


def train(
    update: UpdateFn,
    train_state: TrainState,
    num_iterations: int,
    block_size: int = 10,
    callbacks: Sequence[Callback] = (),
    seeds: bool = False,
    max_consecutive_failures: int = 10,
    iterations_per_call: int | None = None,
) -> TrainState:
    """Run ``num_iterations`` more iterations from ``train_state``.

    Args:
      update: an algorithm's ``update``.
      train_state: from the algorithm's ``init`` (or ``init_seeds`` with ``seeds=True``).
      num_iterations: how many iterations to run; the last block may be shorter (one extra compile).
      block_size: iterations per compiled call, i.e. how often the host sees metrics.
      callbacks: ``callback(train_state, metrics, first_iteration)`` after each block, where
        ``metrics`` maps names to NumPy arrays ``[n]`` (``[n, num_seeds]`` with seeds) and
        ``first_iteration`` is the 0-based index of the block's first iteration.
      seeds: ``train_state`` has a leading seed axis.
      max_consecutive_failures: raise ``TrainingDiverged`` once this many updates in a row were
        rejected as non-finite.
      iterations_per_call: iterations fused into one compiled ``lax.scan`` inside a block. By
        default the whole block, except with MuJoCo Warp (``impl="warp"``), where the scan over
        iterations runs 4-16x slower than one iteration per call on an H100
        (BENCHMARKS.md), so the default there is 1; the block's metrics are the same either way.
    Returns the final ``TrainState``.
    """
    # Donation needs every leaf in its own buffer (states built eagerly can alias, e.g. an
    # observation stored twice), and a jitted copy also commits the leaves to their device the way
    # the block's outputs are, so the second block reuses the first block's compilation.
    train_state = _private_copy(train_state)
    done = 0
    while done < num_iterations:
        n = min(block_size, num_iterations - done)
        first = int(np.max(jax.device_get(train_state.iteration)))
        chunks = []
        for size in _chunk_sizes(n, iterations_per_call or default_iterations_per_call(train_state, block_size)):
            train_state, chunk = compiled_block(update, size, seeds)(train_state)
            chunks.append(chunk)
        metrics = jax.tree.map(lambda *xs: np.concatenate([np.asarray(x) for x in xs]), *jax.device_get(chunks))
        for callback in callbacks:
            callback(train_state, metrics, first)
        failures = int(np.max(jax.device_get(train_state.failures)))
        if failures >= max_consecutive_failures:
            raise TrainingDiverged(
                f"{failures} consecutive updates produced non-finite parameters or losses "
                f"(iteration {first + n}); stopping instead of training on NaNs"
            )
        done += n
    return train_state
