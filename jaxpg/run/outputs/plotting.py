"""Learning curves of a run directory: ``curves.png``.

    python -m jaxpg.run.outputs.plotting RUN_DIR [RUN_DIR ...] [--out curves.png]

Top panel: episode return of the stochastic (sampling) policy and of the mean (deterministic)
policy over iterations. With several seeds, the line is the mean over seeds and the band spans
their minimum to maximum. A second panel shows the task's score (``task_score``, e.g. the hopper's
forward distance) when it is not the return itself. Several run directories are drawn on the same axes.
"""

from __future__ import annotations

import argparse
import io
import math
import os
import sys
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg.run.outputs import console, metrics_log
from jaxpg.run.outputs.sink import Block, Entry, Sink
from jaxpg.run.rundir import config_io, layout

CURVES = (("return_stochastic", "stochastic policy", "-"), ("return_mean_policy", "mean policy", "--"))
TASK_SCORE_CURVES = (("task_score", "stochastic policy", "-"), ("task_score_mean_policy", "mean policy", "--"))
CURVE_KEYS = tuple(key for key, _, _ in CURVES + TASK_SCORE_CURVES)


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


class CurveHistory(Sink):
    """The plotted metrics of a run (``CURVE_KEYS``), kept by the training process block by block
    so that redrawing ``curves.png`` never re-reads ``metrics.jsonl`` (hundreds of MB for a long
    run of many seeds). The sink of the curves: ``jaxpg.run.training.callbacks.Checkpoints`` draws them
    (``plot_process``) when it writes a checkpoint.

    ``curve(key)`` is ``(iterations [n], values [n, num_seeds])``, NaN where not measured, as
    ``seed_curves`` reads it from records.
    """

    entries = (Entry(layout.CURVES_FILE, temporary=("curves.tmp.png",)),)

    def __init__(self) -> None:
        self._iterations: list[np.ndarray] = []
        self._values: dict[str, list[np.ndarray]] = {key: [] for key in CURVE_KEYS}

    @classmethod
    def from_records(cls, records: Sequence[dict[str, Any]]) -> CurveHistory:
        """The history of ``metrics.jsonl``'s records (a resumed run's, or a finished run's)."""
        history = cls()
        if records:
            iterations = None
            for key in CURVE_KEYS:
                iterations, values = seed_curves(records, key)
                history._values[key].append(values)
            history._iterations.append(iterations)
        return history

    @classmethod
    def open(cls, plan: Any, printer: Any) -> CurveHistory:
        """A run's history: a resumed run's starts from its ``metrics.jsonl``, read once (truncated
        to ``plan.start`` already)."""
        return cls.from_records(metrics_log.read_metrics(plan.run_dir) if plan.start else [])

    def write_block(self, block: Block) -> None:
        self.add_block(block.metrics, block.first)

    def add_block(self, metrics: dict[str, np.ndarray], first_iteration: int) -> None:
        """Append a block of ``update`` metrics (``[n]`` or ``[n, num_seeds]`` arrays) whose first
        iteration has 0-based index ``first_iteration``."""
        shape = next(iter(metrics.values())).shape
        n = shape[0]
        self._iterations.append(np.arange(first_iteration + 1, first_iteration + n + 1, dtype=np.int64))
        for key in CURVE_KEYS:
            values = metrics.get(key)
            column = np.full(shape, np.nan) if values is None else np.asarray(values, np.float64)
            self._values[key].append(column.reshape(n, -1))

    def curve(self, key: str) -> tuple[np.ndarray, np.ndarray]:
        """``(iterations [n], values [n, num_seeds])`` of ``key`` (one of ``CURVE_KEYS``)."""
        if not self._iterations:
            return np.zeros(0, np.int64), np.zeros((0, 0))
        return np.concatenate(self._iterations), np.concatenate(self._values[key])

    def to_npz(self) -> bytes:
        """The history as ``.npz`` bytes (``from_npz`` reads them back): ``iterations [n]`` and each
        key's ``[n, num_seeds]``."""
        buffer = io.BytesIO()
        iterations, _ = self.curve(CURVE_KEYS[0])
        np.savez(buffer, iterations=iterations, **{key: self.curve(key)[1] for key in CURVE_KEYS})
        return buffer.getvalue()

    @classmethod
    def from_npz(cls, data: bytes) -> CurveHistory:
        """The history that ``to_npz`` wrote."""
        history = cls()
        with np.load(io.BytesIO(data)) as arrays:
            if len(arrays["iterations"]):
                history._iterations.append(arrays["iterations"])
                for key in CURVE_KEYS:
                    history._values[key].append(arrays[key])
        return history

    def measured(self, key: str) -> bool:
        """Whether any iteration of any seed measured ``key``."""
        return any(np.isfinite(v).any() for v in self._values[key])


def _draw(
    ax: Any,
    history: CurveHistory,
    curves: Sequence[tuple[str, str, str]],
    colors: Sequence[Any],
    label: str,
) -> bool:
    drawn = False
    for (key, name, style), color in zip(curves, colors, strict=True):
        iterations, values = history.curve(key)
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
    runs: Sequence[tuple[str, Sequence[dict[str, Any]] | CurveHistory]],
    path: str | os.PathLike,
    title: str | None = None,
    task_score_name: str | None = None,
) -> Path:
    """Draw ``[(label, records or CurveHistory)]`` into ``path`` (png, pdf, svg ...) and return the path."""
    # Here, not at the top: matplotlib is slow to import, which a run pays at its first plot,
    # after its first block, not before its first line.
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    histories = [(label, h if isinstance(h, CurveHistory) else CurveHistory.from_records(h)) for label, h in runs]
    show_task_score = task_score_name not in (None, "return") and any(
        h.measured(key) for _, h in histories for key, _, _ in TASK_SCORE_CURVES
    )
    fig, axes = plt.subplots(
        2 if show_task_score else 1, 1, figsize=(7.5, 7.0 if show_task_score else 4.2), sharex=True, squeeze=False
    )
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (label, history) in enumerate(histories):
        # One run: a colour per curve; several: a colour per run (line style tells the curves apart).
        prefix = f"{label}: " if len(histories) > 1 else ""
        pair = colors[:2] if len(histories) == 1 else [colors[i % len(colors)]] * 2
        _draw(axes[0, 0], history, CURVES, pair, prefix)
        if show_task_score:
            _draw(axes[1, 0], history, TASK_SCORE_CURVES, pair, prefix)
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
    run_dir: str | os.PathLike,
    path: str | os.PathLike | None = None,
    task_score_name: str | None = None,
    history: CurveHistory | None = None,
) -> Path:
    """``curves.png`` of one run directory, from ``history`` (the training process's) or else its
    ``metrics.jsonl``."""
    run_dir = Path(run_dir)
    run = config_io.RunConfig.load(run_dir)
    if history is None:
        history = CurveHistory.from_records(metrics_log.read_metrics(run_dir / layout.METRICS_FILE))
    out = run_dir / layout.CURVES_FILE if path is None else Path(path)
    return plot_runs([(run_dir.name, history)], out, title=run_title(run), task_score_name=task_score_name)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m jaxpg.run.outputs.plotting", description=__doc__.split("\n\n")[0])
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
