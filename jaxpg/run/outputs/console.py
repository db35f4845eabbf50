"""What a run prints: the one-line summary of a block of iterations, the line about its rolled-back
updates, and the progress bar."""

from __future__ import annotations

import math
import sys
import warnings
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from jaxpg.run.outputs.metrics_log import latest_value
from jaxpg.run.outputs.sink import Block, Sink

# Diagnostics shown in the summary line when the algorithm reports them.
SUMMARY_DIAGNOSTICS = ("kl", "entropy", "step_length", "value_loss", "grad_norm", "cg_residual", "loss")


def _block_stat(values: np.ndarray) -> tuple[float, float]:
    """Mean over the block's iterations (NaN-aware), then mean and std over seeds."""
    values = np.asarray(values, np.float64)
    with np.errstate(all="ignore"), _quiet_nan_warnings():
        per_seed = np.nanmean(values, axis=0) if values.ndim > 1 else np.array([np.nanmean(values)])
        if np.all(np.isnan(per_seed)):
            return math.nan, math.nan
        return float(np.nanmean(per_seed)), float(np.nanstd(per_seed))


class _quiet_nan_warnings:
    def __enter__(self) -> None:

        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()
        warnings.simplefilter("ignore", category=RuntimeWarning)

    def __exit__(self, *exc: Any) -> None:
        self._ctx.__exit__(*exc)


def _fmt(x: float, digits: int = 4) -> str:
    if math.isnan(x):
        return "-"
    if x != 0 and (abs(x) >= 1e5 or abs(x) < 1e-3):
        return f"{x:.{digits - 1}e}"
    return f"{x:.{digits}g}" if abs(x) < 1 else f"{x:.1f}"


def _rate(x: float) -> str:
    for unit, scale in (("M", 1e6), ("k", 1e3)):
        if x >= scale:
            return f"{x / scale:.1f}{unit}"
    return f"{x:.0f}"


def _duration(seconds: float) -> str:
    seconds = max(0, round(seconds))
    return (
        f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"
        if seconds >= 3600
        else f"{seconds // 60}:{seconds % 60:02d}"
    )


def rejection_line(metrics: dict[str, np.ndarray], first: int, max_update_kl: float, normalized: bool) -> str | None:
    """One line about the updates of a block that were rolled back (``None`` if none was).

    ``metrics``: the block's ``[iterations]`` or ``[iterations, seeds]`` arrays, with
    ``update_rejected``, ``kl`` and ``consecutive_failures`` (non-finite updates in a row);
    ``first``: the iteration before the block. It names the causes: the largest mean KL of an
    update above ``max_update_kl``, updates the algorithm itself did not accept (NPG's
    backtracking found no step within its bound), non-finite values. A run that normalises its
    observations (``normalized``) acts in iteration 1 on observations its statistics have not
    seen yet (they start from iteration 1's batch), so a first update that overshoots there is
    expected and said so in a ``note:``, not a warning.
    """
    n = len(metrics["update_rejected"])
    rejected = np.asarray(metrics["update_rejected"]).reshape(n, -1) > 0
    if not rejected.any():
        return None
    nonfinite = rejected & (np.asarray(metrics["consecutive_failures"]).reshape(n, -1) > 0)
    kl = np.asarray(metrics["kl"], np.float64).reshape(n, -1)
    over_kl = rejected & ~nonfinite & (kl > max_update_kl) if max_update_kl > 0 else np.zeros_like(rejected)
    not_accepted = rejected & ~nonfinite & ~over_kl
    causes = []
    if over_kl.any():
        causes.append(f"largest mean KL {_fmt(float(kl[over_kl].max()))}, above max_update_kl {max_update_kl:g}")
    for rows, what in ((not_accepted, "no step the algorithm accepted"), (nonfinite, "non-finite values")):
        if rows.any():
            causes.append(f"{int(rows.any(axis=1).sum())} with {what}")
    iterations = np.flatnonzero(rejected.any(axis=1))
    if normalized and first == 0 and iterations.tolist() == [0] and over_kl.any() and len(causes) == 1:
        return (
            f"note: iteration 1's update was rolled back ({causes[0]}): its policy acts on observations "
            "not yet normalised (the statistics start from its batch), which can make a first update overshoot; "
            "training goes on with iteration 2"
        )
    return (
        f"warning: {iterations.size} of iterations {first + 1}-{first + n} were rolled back ({'; '.join(causes)}); "
        "lower the step size or learning rate"
    )


def summary_line(
    metrics: dict[str, np.ndarray],
    last_iteration: int,
    total: int,
    steps_per_s: float,
    note: str = "",
    eta_s: float | None = None,
) -> str:
    """One line about a logging block: progress, time left, throughput, returns (mean over the
    block's iterations; ``mean +- std`` over seeds) and the algorithm's main diagnostics.

    ``eta_s``: the estimated seconds left (``None``: not known yet, e.g. while compiling)."""
    several = np.ndim(next(iter(metrics.values()))) > 1

    def stat(key: str, digits: int = 4, spread: bool = True) -> str:
        mean, std = _block_stat(metrics[key])
        text = _fmt(mean, digits)
        if spread and several and not math.isnan(std):
            text += f"±{_fmt(std, 3)}"
        return text

    width = len(str(total))
    parts = [f"[{last_iteration:>{width}}/{total}]"]
    if eta_s is not None and last_iteration < total:
        parts.append(f"ETA {_duration(eta_s)}")
    if "env_steps" in metrics:
        steps = float(np.max(metrics["env_steps"]))
        parts.append(f"steps {steps:,.0f}")
    parts.append(f"{_rate(steps_per_s)} steps/s{note}")
    returns = []
    if "return_stochastic" in metrics:
        returns.append(f"return {stat('return_stochastic')}")
    if "return_mean_policy" in metrics:
        returns.append(f"mean policy {stat('return_mean_policy')}")
    if returns:
        parts.append(" ".join(returns))
    if "episode_length" in metrics:
        parts.append(f"len {stat('episode_length', 3)}")
    for key in SUMMARY_DIAGNOSTICS:
        if key in metrics:
            parts.append(f"{key} {stat(key, 3, spread=False)}")
    for key in ("update_rejected", "nonfinite"):
        if key in metrics and np.nansum(metrics[key]) > 0:
            parts.append(f"{key} {np.nansum(metrics[key]):.0f}")
    return " | ".join(parts)


class Progress(Sink):
    """The console's sink: a tqdm bar over iterations (hidden when stderr is not a terminal) plus
    summary lines; it writes nothing in the run directory.

    ``update`` (``write_block``) advances the bar by a block and shows env steps/s and the latest
    returns; ``write`` prints a line above the bar (to stdout).
    """

    def __init__(self, total: int, initial: int = 0, enabled: bool | None = None, desc: str = "train"):
        disable = None if enabled is None else not enabled
        self.bar = tqdm(total=total, initial=initial, desc=desc, unit="it", dynamic_ncols=True, disable=disable)

    @classmethod
    def open(cls, plan: Any, printer: Any) -> Progress:
        run = plan.run
        return cls(run.iterations, initial=plan.start, enabled=plan.progress, desc=f"{run.algo} {run.task}")

    def write_block(self, block: Block) -> None:
        self.update(len(next(iter(block.metrics.values()))), block.metrics, block.steps_per_s)

    def update(self, n: int, metrics: dict[str, np.ndarray], steps_per_s: float) -> None:
        postfix = {"steps/s": _rate(steps_per_s)}
        for key, label in (("return_stochastic", "R"), ("return_mean_policy", "R_mean")):
            if key in metrics:
                latest = latest_value(metrics[key])
                if not math.isnan(latest):
                    postfix[label] = _fmt(latest)
        self.bar.set_postfix(postfix, refresh=False)
        self.bar.update(n)

    def write(self, line: str) -> None:
        tqdm.write(line, file=sys.stdout)

    def close(self) -> None:
        self.bar.close()
