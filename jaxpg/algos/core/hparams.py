"""Hyperparameters as data: the numeric fields of a config that an update may read as traced
arrays, so that one compiled program ``vmap``-s over many configurations.

A config's ``TRACED_FIELDS`` (gathered over its classes, ``traced_fields``) are the numeric fields
that change no array's shape and no optimizer state's layout: learning rates, coefficients,
discounts, trust-region sizes, clip ranges, epsilons, log-std settings, annealing horizons. All
the other fields (shapes, counts of epochs and minibatches, names, booleans) are the program's
*structure* and stay static in ``TrainState.config``. A traced field that also switches a piece of
the program on or off (``SWITCH_FIELDS``: e.g. ``max_grad_norm`` 0 removes the clipping,
``anneal_lr_iterations`` 0 the schedule) is structure as far as *whether* it is on: runs that share
a program agree on that (``program_key``).

``TrainState.hparams`` holds the traced values: ``()`` (the default) reads every field from the
static config, exactly as before; ``hyperparameters(config)`` gives the dict of ``[]`` arrays
(float32, int32 for counts) that ``with_hyperparameters`` puts in a state. An update reads numbers
through ``run_config(ts)`` (the static config with the traced values in place) and decides
structure from ``ts.config``.

Bit-exactness. A run given its numbers as data computes the same bits as the static program on
the same device. Two things differ between a Python number baked into a program and an array fed
to it, and both are handled here: arithmetic between two fields that the static path does in
Python double precision (``gamma * gae_lambda``, ``1 - clip_eps`` ...) is done on the host too and
carried as a ``DERIVED`` entry (``derived``); and XLA rewrites a division by a constant into a
multiplication by its float32 reciprocal, which ``divide`` repeats for a traced divisor.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from jaxpg.algos.core.config import NO_LOG_STD_FLOOR

# Quantities the static path computes from two fields in Python (double precision) before they
# reach the program: carried precomputed, so that the traced path rounds them the same way.
DERIVED: dict[str, tuple[tuple[str, ...], Callable[[Any], float]]] = {
    "gamma*gae_lambda": (("gamma", "gae_lambda"), lambda c: c.gamma * c.gae_lambda),
    "1-clip_eps": (("clip_eps",), lambda c: 1.0 - c.clip_eps),
    "1+clip_eps": (("clip_eps",), lambda c: 1.0 + c.clip_eps),
    "log_std_final-log_std_init": (("log_std_final", "log_std_init"), lambda c: c.log_std_final - c.log_std_init),
    "2*max_kl": (("max_kl",), lambda c: 2.0 * c.max_kl),
}

# Traced fields whose value also decides whether a piece of the program exists: ``is_on`` of
# the value. Runs that share one program agree on it.
SWITCH_FIELDS: dict[str, Callable[[float], bool]] = {
    "max_update_kl": lambda v: v > 0,
    "log_std_min": lambda v: v > NO_LOG_STD_FLOOR,
    "anneal_log_std_iterations": lambda v: v > 0,
    "anneal_kl_iterations": lambda v: v > 0,
    "anneal_lr_iterations": lambda v: v > 0,
    "max_grad_norm": lambda v: v > 0,
    "value_clip_eps": lambda v: v > 0,
    "value_lr": lambda v: v > 0,
}


def traced_fields(config: Any) -> tuple[str, ...]:
    """The names of ``config``'s fields (a config instance or class) that may be traced: the union
    of ``TRACED_FIELDS`` over its classes, in field order."""
    cls = config if isinstance(config, type) else type(config)
    names = set()
    for klass in cls.__mro__:
        names.update(klass.__dict__.get("TRACED_FIELDS", ()))
    return tuple(f.name for f in dataclasses.fields(cls) if f.name in names)


def switch_states(config: Any) -> tuple[tuple[str, bool], ...]:
    """``(field, on)`` for each traced field of ``config`` that switches a piece of the program."""
    names = [name for name in traced_fields(config) if name in SWITCH_FIELDS]
    return tuple((name, SWITCH_FIELDS[name](getattr(config, name))) for name in names)


def program_key(config: Any) -> tuple:
    """What decides ``config``'s compiled program: its class, every field that is not traced, and
    the on/off state of the switching traced fields. Configs with equal keys train in one program."""
    traced = set(traced_fields(config))
    static = tuple((f.name, getattr(config, f.name)) for f in dataclasses.fields(config) if f.name not in traced)
    return (type(config).__module__, type(config).__qualname__, static, switch_states(config))


def _derived_names(config: Any) -> tuple[str, ...]:
    fields = {f.name for f in dataclasses.fields(config)}
    return tuple(name for name, (needs, _) in DERIVED.items() if set(needs) <= fields)


def hyperparameters(config: Any) -> dict[str, jax.Array]:
    """``config``'s traced values as ``[]`` arrays (float32; int32 for integer fields), with its
    ``DERIVED`` quantities: what ``TrainState.hparams`` holds for one run. Stack several with
    ``jax.tree.map(lambda *x: jnp.stack(x), ...)`` for a batch of runs."""
    values: dict[str, jax.Array] = {}
    for name in traced_fields(config):
        value = getattr(config, name)
        dtype = jnp.int32 if isinstance(value, int) and not isinstance(value, bool) else jnp.float32
        values[name] = jnp.asarray(value, dtype)
    for name in _derived_names(config):
        values[name] = jnp.asarray(DERIVED[name][1](config), jnp.float32)
    return values


def is_traced(ts: Any) -> bool:
    """Whether ``ts`` carries its hyperparameters as data (``TrainState.hparams`` not empty; a
    state-like object without the attribute does not)."""
    return bool(getattr(ts, "hparams", ()))


def run_config(ts: Any) -> Any:
    """The config whose numbers ``ts``'s update uses: ``ts.config`` itself, or with
    ``ts.hparams``' traced values in place of its traced fields. Read structure (Python ``if``s,
    shapes) from ``ts.config``, never from this: its traced fields are arrays. A switch field that
    is off in ``ts.config`` keeps its static value: every run of the program has it off, and any
    off value (0, or no log-std floor) acts alike."""
    if not is_traced(ts):
        return ts.config
    off = {name for name, on in switch_states(ts.config) if not on}
    names = set(traced_fields(ts.config)) - off
    return dataclasses.replace(ts.config, **{k: v for k, v in ts.hparams.items() if k in names})


def derived(ts: Any, name: str) -> Any:
    """The ``DERIVED`` quantity ``name`` of ``ts``'s run: computed from the static config in Python
    (a float), or the traced value computed the same way on the host."""
    if not is_traced(ts):
        return DERIVED[name][1](ts.config)
    return ts.hparams[name]


def divide(x: jax.Array, divisor: Any) -> jax.Array:
    """``x / divisor`` as the static program computes it: a Python-number divisor is a constant,
    which XLA turns into a multiplication by its float32 reciprocal; a traced divisor gets that
    same multiplication, so that both round alike."""
    if isinstance(divisor, int | float):
        return x / divisor
    return x * (1.0 / jnp.asarray(divisor, jnp.float32))


def with_hyperparameters(ts: Any, hparams: dict[str, jax.Array]) -> Any:
    """``ts`` reading its numbers from ``hparams`` (``hyperparameters``' dict, possibly of
    tracers): stored in ``ts.hparams``, and the ``gaussian`` policy's initial log-std set to
    ``hparams["log_std_init"]`` as ``init`` would have set it."""
    missing = set(hyperparameters_names(ts.config)) - set(hparams)
    if missing:
        raise ValueError(f"hparams lacks {', '.join(sorted(missing))}")
    params = ts.params
    if isinstance(params, dict) and "log_std" in params and "log_std_init" in hparams:
        shape = params["log_std"].shape
        params = {**params, "log_std": jnp.full(shape, hparams["log_std_init"], jnp.float32)}
    return ts.replace(params=params, hparams=dict(hparams))


def hyperparameters_names(config: Any) -> tuple[str, ...]:
    """The keys of ``hyperparameters(config)``."""
    return traced_fields(config) + _derived_names(config)
