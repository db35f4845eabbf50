"""The figures of a sweep report (``jaxpg.sweep.report``): learning curves with interval bands and
sensitivity plots, drawn with Matplotlib's non-interactive backend."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg.sweep import stats

# The learning-curve figures: at most this many configurations (the best by IQM), each drawn at
# this many evenly spaced iterations.
MAX_CURVES = 8
CURVE_POINTS = 25


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def curve_band(curves: list[np.ndarray], points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """IQM over runs of ``curves`` (each ``[iterations]``) at iteration indices ``points``, with
    its 95 % bootstrap interval: ``(iqm, low, high)``, each ``[len(points)]``."""
    values = np.stack(curves)[:, points]
    out = np.array([stats.interval([values[:, j]], stats.iqm, seed=j) for j in range(len(points))])
    return out[:, 0], out[:, 1], out[:, 2]


def learning_curves(report: Any, x_name: str, path: Path) -> None:
    """Training return against ``x_name`` (``"env_steps"`` or ``"wall_s"``) of the best
    configurations (``MAX_CURVES`` by IQM score), IQM over seeds with a 95 % band."""

    plt = _pyplot()
    best = sorted(report.configurations, key=lambda r: -r["iqm"] if math.isfinite(r["iqm"]) else math.inf)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for row in best[:MAX_CURVES]:
        runs = [r["run"] for r in report.runs if r["configuration"] == row["configuration"]]
        curves = [report.curves[i]["return"] for i in runs]
        iterations = len(curves[0])
        points = np.unique(np.linspace(0, iterations - 1, min(CURVE_POINTS, iterations)).astype(int))
        x = np.mean([report.curves[i][x_name][points] for i in runs], axis=0)
        mid, low, high = curve_band(curves, points)
        ax.plot(x, mid, label=row["label"])
        ax.fill_between(x, low, high, alpha=0.2)
    ax.set_xlabel("env steps" if x_name == "env_steps" else "wall clock (s, all runs of a chunk together)")
    ax.set_ylabel("training return (IQM over seeds, 95% CI)")
    ax.set_title(f"{report.spec.algo} on {report.spec.task}")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def sensitivity(report: Any, field: str, path: Path) -> None:
    """Each configuration's IQM score (95 % interval) against its value of ``field``; log x for
    positive values spanning more than a factor of 10."""
    plt = _pyplot()
    rows = sorted(report.configurations, key=lambda r: r[field])
    x = np.array([float(r[field]) for r in rows])
    mid = np.array([r["iqm"] for r in rows])
    err = np.array([[r["iqm"] - r["iqm_low"] for r in rows], [r["iqm_high"] - r["iqm"] for r in rows]])
    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.errorbar(x, mid, yerr=err, fmt="o", capsize=3, alpha=0.8)
    if np.all(x > 0) and x.max() > 10 * x.min():
        ax.set_xscale("log")
    ax.set_xlabel(field)
    ax.set_ylabel(f"{rows[0]['scored_by']} (IQM over seeds, 95% CI)")
    ax.set_title(f"{report.spec.algo} on {report.spec.task}: sensitivity to {field}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def draw(report: Any, folder: Path) -> list[Path]:
    """Every figure of ``report`` into ``folder``; returns their paths."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / "return_vs_env_steps.png", folder / "return_vs_wall_clock.png"]
    learning_curves(report, "env_steps", paths[0])
    learning_curves(report, "wall_s", paths[1])
    for field in report.swept:
        path = folder / f"sensitivity_{field}.png"
        sensitivity(report, field, path)
        paths.append(path)
    return paths
