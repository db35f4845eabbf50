"""``suite.py plot``: mean-policy return against wall clock and env steps, from ``run --json`` files."""

from __future__ import annotations

import argparse
import math
import statistics
from collections.abc import Sequence

import harness

RAW = argparse.RawDescriptionHelpFormatter


PLOT_DOC = """Mean-policy return against wall clock and against env steps, one column per task.

Reads ``run --json`` files; each TASK:ALGO:PRESET is a line (the median over seeds) in a band (the
lowest to the highest seed), on a common grid of wall-clock seconds and of env steps.

    python benchmarks/suite.py plot suite.json --out docs/suite.png
    python benchmarks/suite.py count blocks/*.json --bar 3000
"""


def band(curves: list[list[tuple[float, float]]], grid: list[float]) -> tuple[list[float], list[float], list[float]]:
    """Lowest, median and highest return over ``curves`` (each ``[(x, return)]``, x increasing) at
    each point of ``grid``, holding each curve's last value before that point (NaN before its
    first)."""

    def at(curve: list[tuple[float, float]], x: float) -> float:
        seen = [r for cx, r in curve if cx <= x]
        return seen[-1] if seen else math.nan

    lows, mids, highs = [], [], []
    for x in grid:
        values = [v for v in (at(c, x) for c in curves) if not math.isnan(v)]
        lows.append(min(values) if values else math.nan)
        mids.append(statistics.median(values) if values else math.nan)
        highs.append(max(values) if values else math.nan)
    return lows, mids, highs


def plot_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="suite.py plot", description=PLOT_DOC, formatter_class=RAW)
    parser.add_argument("files", nargs="+")
    parser.add_argument("--out", default="suite.png")
    args = parser.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [row for path in args.files for row in harness.rows_of(path)]
    tasks = list(dict.fromkeys(row["task"] for row in rows))
    fig, axes = plt.subplots(2, len(tasks), figsize=(4 * len(tasks), 6.5), squeeze=False)
    for column, task in enumerate(tasks):
        runs: dict[str, list[dict]] = {}
        for row in rows:
            if row["task"] == task:
                runs.setdefault(f"{row['algo']}:{row['preset']}", []).append(row)
        for axis_row, (index, label) in enumerate(((0, "training wall clock (s)"), (1, "env steps"))):
            ax = axes[axis_row][column]
            for name, seeds in runs.items():
                curves = [[(point[index], point[2]) for point in row["curve"]] for row in seeds]
                end = max((c[-1][0] for c in curves if c), default=0.0)
                grid = [end * i / 200 for i in range(201)]
                low, mid, high = band(curves, grid)
                ax.plot(grid, mid, label=name)
                ax.fill_between(grid, low, high, alpha=0.25)
            ax.set_xlabel(label)
            ax.set_ylabel("mean-policy return")
            ax.set_title(task)
            ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")
