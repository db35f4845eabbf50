"""Learning curves of a run directory: ``curves.png``.

    python -m jaxpg.run.plotting RUN_DIR [RUN_DIR ...] [--out curves.png]

Top panel: episode return of the stochastic (sampling) policy and of the mean (deterministic)
policy over iterations. With several seeds, the line is the mean over seeds and the band spans
their minimum to maximum. A second panel shows the task's score (``task_score``, e.g. the hopper's
forward distance) when it is not the return itself. Several run directories are drawn on the same axes.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg.run import config_io, console, layout, metrics_log

CURVES = (("return_stochastic", "stochastic policy", "-"), ("return_mean_policy", "mean policy", "--"))
TASK_SCORE_CURVES = (("task_score", "stochastic policy", "-"), ("task_score_mean_policy", "mean policy", "--"))


def seed_curves(records: Sequence[dict[str, Any]], key: str) -> tuple[np.ndarray, np.ndarray]:
    """``(iterations [n], values [n, num_seeds])`` of ``key``; NaN where not measured."""
    by_seed: dict[Any, dict[int, float]] = defaultdict(dict)
    for r in records:
        value = r.get(key)
        by_seed[r.get("seed", 0)][r["iteration"]] = math.nan if value is None else float(value)
    iterations = np.array(sorted({it for values in by_seed.values() for it in values}), np.int64)
    seeds = sorted(by_seed)
    values = np.full((len(iterations), len(seeds)), np.nan)
    index = {it: i for i, it in enumerate(iterations)}
    for j, seed in enumerate(seeds):
        for it, v in by_seed[seed].items():
            values[index[it], j] = v
    return iterations, values


def _draw(
    ax: Any,
    records: Sequence[dict[str, Any]],
    curves: Sequence[tuple[str, str, str]],
    colors: Sequence[Any],
    label: str,
) -> bool:
    drawn = False
    for (key, name, style), color in zip(curves, colors, strict=True):
        iterations, values = seed_curves(records, key)
        if values.size == 0:
            continue
        rows = ~np.all(np.isnan(values), axis=1)  # iterations where any seed measured it
        if not rows.any():
            continue
        x, v = iterations[rows], values[rows]
        with np.errstate(all="ignore"), console._quiet_nan_warnings():
            mean = np.nanmean(v, axis=1)
            lo, hi = np.nanmin(v, axis=1), np.nanmax(v, axis=1)
        text = f"{label}{name}" + (f" (mean of {v.shape[1]} seeds, min-max band)" if v.shape[1] > 1 else "")
        ax.plot(x, mean, style, color=color, label=text, marker="." if len(x) < 30 else None)
        if v.shape[1] > 1:
            ax.fill_between(x, lo, hi, color=color, alpha=0.2, linewidth=0)
        drawn = True
    return drawn


def plot_runs(
    runs: Sequence[tuple[str, Sequence[dict[str, Any]]]],
    path: str | os.PathLike,
    title: str | None = None,
    task_score_name: str | None = None,
) -> Path:
    """Draw ``[(label, records)]`` into ``path`` (png, pdf, svg ...) and return the path."""
    # Here, not at the top: matplotlib takes 0.4 s to import, which a run pays at its first plot,
    # after its first block, not before its first line.
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    show_task_score = task_score_name not in (None, "return") and any(
        r.get("task_score") is not None or r.get("task_score_mean_policy") is not None
        for _, records in runs
        for r in records
    )
    fig, axes = plt.subplots(
        2 if show_task_score else 1, 1, figsize=(7.5, 7.0 if show_task_score else 4.2), sharex=True, squeeze=False
    )
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (label, records) in enumerate(runs):
        # One run: a colour per curve; several: a colour per run (line style tells the curves apart).
        prefix = f"{label}: " if len(runs) > 1 else ""
        pair = colors[:2] if len(runs) == 1 else [colors[i % len(colors)]] * 2
        _draw(axes[0, 0], records, CURVES, pair, prefix)
        if show_task_score:
            _draw(axes[1, 0], records, TASK_SCORE_CURVES, pair, prefix)
    axes[0, 0].set_ylabel("episode return")
    if show_task_score:
        axes[1, 0].set_ylabel(str(task_score_name).replace("_", " "))
    axes[-1, 0].set_xlabel("iteration")
    axes[-1, 0].xaxis.set_major_locator(MaxNLocator(integer=True))
    for ax in axes[:, 0]:
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8, loc="best")
    if title:
        axes[0, 0].set_title(title, fontsize=10)
    fig.tight_layout()
    path = Path(path)
    tmp = path.with_name(path.stem + ".tmp" + path.suffix)
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)
    return path


def run_title(run: config_io.RunConfig) -> str:
    seeds = f"seed {run.seeds[0]}" if len(run.seeds) == 1 else f"seeds {' '.join(map(str, run.seeds))}"
    preset = f", preset {run.preset}" if run.preset else ""
    return f"{run.algo.upper()} on {run.task}{preset}, {seeds}"


def plot_run(
    run_dir: str | os.PathLike, path: str | os.PathLike | None = None, task_score_name: str | None = None
) -> Path:
    """``curves.png`` of one run directory (from its ``metrics.jsonl``)."""
    run_dir = Path(run_dir)
    run = config_io.RunConfig.load(run_dir)
    records = metrics_log.read_metrics(run_dir / layout.METRICS_FILE)
    out = run_dir / layout.CURVES_FILE if path is None else Path(path)
    return plot_runs([(run_dir.name, records)], out, title=run_title(run), task_score_name=task_score_name)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m jaxpg.run.plotting", description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dirs", nargs="+", help="run directories (several: drawn on the same axes)")
    parser.add_argument("--out", help="output image (default: RUN_DIR/curves.png for one run, curves.png otherwise)")
    args = parser.parse_args(argv)
    try:
        runs = []
        for d in args.run_dirs:
            config_io.RunConfig.load(d)
            runs.append((Path(d).name, metrics_log.read_metrics(Path(d) / layout.METRICS_FILE)))
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if len(runs) == 1:
        out = plot_run(args.run_dirs[0], args.out)
    else:
        out = plot_runs(runs, args.out or "curves.png")
    print(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
