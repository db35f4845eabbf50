"""Divergence: a block of iterations whose state or metrics no healthy run has. The run stops
before the block is checkpointed (``guard_divergence``, a host callback), so that every
checkpoint on disk holds a state that passed this check and good checkpoints are never rotated
out for bad ones.

A block has diverged when, for any seed:
  - a floating array of the policy or value parameters or of the observation statistics is not
    finite;
  - a policy parameter is larger than ``MAX_PARAMETER`` in magnitude, or the Gaussian policy's
    log-std leaves ``[-MAX_LOG_STD, MAX_LOG_STD]`` (a std that float32 actions of order one cannot
    resolve, or that swamps them);
  - an update that was accepted (``update_rejected`` 0) has a non-finite mean KL or one above
    ``MAX_KL`` nats, or a non-finite entropy, or an entropy per action dimension outside
    ``[-MAX_LOG_STD, MAX_LOG_STD]`` plus a Gaussian's ``0.5 * log(2 pi e)``;
  - every sample of an iteration was non-finite (``nonfinite`` equals the samples drawn): the
    physics, not the policy, has broken down.
Updates that the algorithm's own guard rolled back (``--max-update-kl``, non-finite losses) are
not divergence: their state was never kept.
"""

from __future__ import annotations

import math
from typing import Any

import jax
import numpy as np

from jaxpg import train

MAX_LOG_STD = 20.0
"""Largest magnitude of a healthy log-std: a std outside ``[2e-9, 4.9e8]``."""

MAX_PARAMETER = 1e6
"""Largest magnitude of a healthy policy parameter."""

MAX_KL = 1e3
"""Largest mean KL (nats) of a healthy accepted update: far beyond any trust region jaxpg uses."""

GAUSSIAN_ENTROPY_OFFSET = 0.5 * math.log(2 * math.pi * math.e)
"""A Gaussian's entropy per dimension is its log-std plus this."""


def _first_bad(values: np.ndarray, bad: np.ndarray, first: int) -> tuple[int, int] | None:
    """``(iteration, seed index)`` of the first ``True`` of ``bad`` (``[n]`` or ``[n, seeds]``)."""
    hits = np.argwhere(np.asarray(bad).reshape(len(values), -1))
    if not len(hits):
        return None
    row, column = hits[0]
    return first + int(row) + 1, int(column)


def metrics_problem(
    metrics: dict[str, np.ndarray], first: int, samples_per_iteration: int, action_size: int
) -> tuple[int, int, str] | None:
    """The first sign of divergence in a block of ``update`` metrics (``[n]`` or ``[n, seeds]``
    arrays; ``first``: the 0-based index of its first iteration), as ``(iteration, seed index,
    what)``, or ``None``. ``samples_per_iteration``: samples one seed draws per iteration;
    ``action_size``: the dimensions of a continuous action (entropy per dimension)."""
    n = len(next(iter(metrics.values())))
    accepted = np.ones((n, 1), bool)
    if "update_rejected" in metrics:
        accepted = np.asarray(metrics["update_rejected"]).reshape(n, -1) == 0
    checks = []
    if "kl" in metrics:
        kl = np.asarray(metrics["kl"], np.float64).reshape(n, -1)
        checks.append((accepted & ~np.isfinite(kl), kl, "the mean KL of an accepted update is {:g}"))
        with np.errstate(invalid="ignore"):
            checks.append(
                (accepted & (kl > MAX_KL), kl, "the mean KL of an accepted update is {:g} nats, above " + f"{MAX_KL:g}")
            )
    if "entropy" in metrics:
        entropy = np.asarray(metrics["entropy"], np.float64).reshape(n, -1)
        per_dim = entropy / max(action_size, 1) - GAUSSIAN_ENTROPY_OFFSET
        checks.append((accepted & ~np.isfinite(entropy), entropy, "the policy's entropy is {:g}"))
        with np.errstate(invalid="ignore"):
            checks.append(
                (
                    accepted & (np.abs(per_dim) > MAX_LOG_STD),
                    entropy,
                    "the policy's entropy is {:g}, a log-std beyond " + f"+-{MAX_LOG_STD:g}",
                )
            )
    if "nonfinite" in metrics:
        nonfinite = np.asarray(metrics["nonfinite"], np.float64).reshape(n, -1)
        checks.append(
            (
                nonfinite >= samples_per_iteration,
                nonfinite,
                "every one of its {:.0f} samples was non-finite (the physics broke down: check --env-kwargs "
                "and the task's settings)",
            )
        )
    found = []
    for bad, values, text in checks:
        hit = _first_bad(values, bad, first)
        if hit is not None:
            iteration, column = hit
            found.append((iteration, column, text.format(values[iteration - first - 1, column])))
    return min(found, default=None, key=lambda item: item[0])


def state_problem(ts: Any, seeds: bool) -> tuple[int, str] | None:
    """The first sign of divergence in a ``TrainState`` (a leading seed axis when ``seeds``), as
    ``(seed index, what)``, or ``None``: non-finite parameters or statistics, a policy parameter
    or log-std beyond its bound."""
    parts = {
        "policy parameters": ts.params,
        "value parameters": ts.value_params,
        "observation statistics": ts.obs_stats,
    }
    for name, tree in parts.items():
        for leaf in jax.tree.leaves(jax.device_get(tree)):
            array = np.asarray(leaf)
            if not np.issubdtype(array.dtype, np.floating):
                continue
            rows = array.reshape(array.shape[0], -1) if seeds and array.ndim else array.reshape(1, -1)
            bad = ~np.isfinite(rows).all(axis=1)
            if bad.any():
                return int(np.argmax(bad)), f"its {name} are not finite"
    params = jax.device_get(ts.params)
    log_std = params.get("log_std") if hasattr(params, "get") else None  # the Gaussian policy's global log-std
    if log_std is not None:
        rows = np.asarray(log_std).reshape(np.shape(log_std)[0], -1) if seeds else np.asarray(log_std).reshape(1, -1)
        worst = np.abs(rows).max(axis=1)
        if (worst > MAX_LOG_STD).any():
            s = int(np.argmax(worst > MAX_LOG_STD))
            return s, f"its policy's log-std reached {rows[s][np.argmax(np.abs(rows[s]))]:g}, beyond +-{MAX_LOG_STD:g}"
    for leaf in jax.tree.leaves(params):
        array = np.asarray(leaf)
        rows = array.reshape(array.shape[0], -1) if seeds and array.ndim else array.reshape(1, -1)
        worst = np.abs(rows).max(axis=1) if rows.size else np.zeros(1)
        if (worst > MAX_PARAMETER).any():
            s = int(np.argmax(worst > MAX_PARAMETER))
            return s, f"a policy parameter reached {worst[s]:g}, beyond {MAX_PARAMETER:g}"
    return None


def guard_divergence(plan_: Any, checkpoints: Any) -> Any:
    """The host callback that stops a diverged run before its block is checkpointed: raises
    ``jaxpg.train.TrainingDiverged`` with one line naming the iteration, the seed, what went wrong
    and the last good checkpoint (``checkpoints.last_saved``)."""
    run = plan_.run
    samples = plan_.config.samples_per_iteration
    action_size = int(getattr(plan_.env, "action_size", 1) or 1)

    def guard(ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        found = metrics_problem(metrics, first, samples, action_size)
        if found is None:
            state = state_problem(ts, run.vmap_seeds)
            if state is not None:
                found = (first + len(next(iter(metrics.values()))), *state)
        if found is None:
            return
        iteration, column, what = found
        seed = run.seeds[column] if column < len(run.seeds) else run.seeds[0]
        saved = checkpoints.last_saved
        kept = (
            f"; the last good checkpoint, {saved}, is kept and nothing after it was saved (resume from it with "
            "--resume, or from an earlier one with --from-step N)"
            if saved
            else ""
        )
        raise train.TrainingDiverged(f"training diverged at iteration {iteration} (seed {seed}): {what}{kept}")

    return guard
