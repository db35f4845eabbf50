"""Command-line values: the types of flags, and the one-line error for bad input."""

from __future__ import annotations

import argparse
import math
import os

import jax

from jaxpg.run.rundir.layout import MAX_SEED


class UsageError(ValueError):
    """Bad command-line input; reported as one ``error:`` line with exit status 2."""


def finite_float(text: str) -> float:
    """A float flag's value: any number but ``nan`` and ``inf`` (``ArgumentTypeError`` otherwise)."""
    value = float(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text}")
    return value


finite_float.__name__ = "float"  # argparse names the type in "invalid float value: 'x'"


def seed_value(text: str) -> int:
    """A training seed: an integer in ``[0, MAX_SEED]``, so that distinct seeds give
    distinct 32-bit PRNG keys (``ArgumentTypeError`` otherwise)."""
    value = int(text)
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, {MAX_SEED}] (a 32-bit seed), got {text}")
    return value


seed_value.__name__ = "int"


def check_backend() -> None:
    """``UsageError`` (one line) when JAX cannot start a device: the platform ``JAX_PLATFORMS``
    names is not installed or has no usable device."""
    try:
        jax.devices()
    except Exception as e:  # noqa: BLE001 - JAX raises RuntimeError, or AssertionError for a platform it lacks
        lines = str(e).strip().splitlines()
        reason = lines[0] if lines else "no such platform is installed here"
        platforms = os.environ.get("JAX_PLATFORMS")
        what = f"the platform JAX_PLATFORMS={platforms} asks for" if platforms else "any device"
        raise UsageError(
            f"JAX cannot use {what} ({reason}); set JAX_PLATFORMS to one this machine has (e.g. cpu), or unset it"
        ) from None
