"""The value fit every algorithm with a separately fitted value function uses (NPG, TRPO, VPG):
minibatch Adam on the batch's value targets (``jaxpg.value.fit_value``), optionally on targets
standardised by running statistics whose moves the output layer absorbs (PopArt's "preserve
outputs", van Hasselt et al. 2016); PPO and A2C, whose value loss is part of a joint loss, share
the standardisation (``standardise_value_targets``)."""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import optax

from jaxpg import value as value_lib
from jaxpg.algos.core.batch import Batch
from jaxpg.algos.core.config import ValueFitConfig
from jaxpg.algos.core.hparams import is_traced, run_config
from jaxpg.algos.core.state import TrainState


def value_optimizer(config: ValueFitConfig, lr: Any = None) -> optax.GradientTransformation:
    """Adam at ``config.value_fit_lr`` (or ``lr``, e.g. traced): the optimizer of
    ``phase_value_fit``, whose state is ``TrainState.value_opt_state``."""
    return optax.adam(config.value_fit_lr if lr is None else lr)


def value_fit_lr(ts: TrainState) -> Any:
    """The value fit's learning rate for ``ts``'s run: the field ``config.value_fit_lr_field``
    names, read through ``core.run_config`` (a traced ``[]`` array when ``ts`` carries hparams)."""
    if not is_traced(ts):
        return ts.config.value_fit_lr
    return getattr(run_config(ts), ts.config.value_fit_lr_field)


def absorb_value_targets(ts: TrainState, batch: Batch) -> TrainState:
    """``ts`` with the value-target statistics moved by ``batch.value_targets [N]`` (weighted by
    ``batch.weights``) and the value network's output layer rescaled so that its predictions in
    return units stay the same (``value.preserve_outputs``; not before the first batch, when the
    untrained network's outputs carry nothing worth keeping)."""
    stats = ts.value_stats.update(batch.value_targets[:, None], batch.weights)
    old = ts.value_stats
    preserved = value_lib.preserve_outputs(ts.value_params, old.mean[0], old.std[0], stats.mean[0], stats.std[0])
    seen = old.count > 0
    value_params = jax.tree.map(lambda p, q: jnp.where(seen, p, q), preserved, ts.value_params)
    return ts.replace(value_params=value_params, value_stats=stats)


def standardise_value_targets(ts: TrainState, batch: Batch) -> tuple[TrainState, Batch]:
    """With ``config.normalize_value_targets``: the target statistics absorb ``batch``'s value
    targets ``[N]`` (``absorb_value_targets``, which rescales the value network's output layer so
    that its predictions in return units stay the same), and the batch comes back with its
    targets standardised by the new statistics, the units the network is trained in. Without
    it, ``ts`` and ``batch`` unchanged."""
    if not ts.config.normalize_value_targets:
        return ts, batch
    ts = absorb_value_targets(ts, batch)
    return ts, standardised_targets(ts, batch)


def standardised_targets(ts: TrainState, batch: Batch) -> Batch:
    """``batch`` with its value targets ``[N]`` in the units the value network is trained in:
    standardised by ``ts.value_stats`` as they stand (nothing absorbed) with
    ``config.normalize_value_targets``, as they are without it."""
    if not ts.config.normalize_value_targets:
        return batch
    stats = ts.value_stats
    return batch.replace(value_targets=(batch.value_targets - stats.mean[0]) / stats.std[0])


def phase_value_fit(ts: TrainState, batch: Batch, key: jax.Array) -> tuple[TrainState, jax.Array]:
    """Fit the value network to ``batch.value_targets``: ``config.value_epochs`` passes of
    minibatch Adam (``value_optimizer``) on the weighted mean squared error, each epoch over at
    most ``config.value_epoch_samples`` samples (when > 0).

    With ``normalize_value_targets`` the statistics first absorb this batch and the network is
    fitted to the standardised targets (``standardise_value_targets``); the loss is
    then in standardised units. Returns the state with the new value parameters, optimizer state
    and statistics, and the loss ``[]`` averaged over the minibatch steps.
    """
    config = ts.config
    ts, batch = standardise_value_targets(ts, batch)
    value_params, value_opt_state, loss = value_lib.fit_value(
        ts.value_fn,
        ts.value_params,
        ts.value_opt_state,
        value_optimizer(config, value_fit_lr(ts)),
        batch.obs,
        batch.value_targets,
        key,
        epochs=config.value_epochs,
        batch_size=config.value_minibatch_size,
        weights=batch.weights,
        samples_per_epoch=config.value_epoch_samples,
    )
    return ts.replace(value_params=value_params, value_opt_state=value_opt_state), loss
