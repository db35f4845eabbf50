"""``time_to_return.py plot``: mean-policy return against wall clock from ``run --json`` files."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

import harness

RAW = argparse.RawDescriptionHelpFormatter


PLOT_DOC = """Plot mean-policy return against wall-clock seconds from ``time_to_return.py run --json`` files.

    python benchmarks/time_to_return.py plot --out docs/hopper_time_to_return.png \
        PPO=benchmarks/results/2026-11-22-h100/ppo.json,benchmarks/results/2026-11-22-h100/ppo12.json \
        NPG=benchmarks/results/2026-11-22-h100/npg.json,benchmarks/results/2026-11-22-h100/npg12.json
"""


def plot_main(argv: Sequence[str]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    parser = argparse.ArgumentParser(prog="time_to_return.py plot", description=PLOT_DOC, formatter_class=RAW)
    parser.add_argument("series", nargs="+", help="LABEL=file.json[,file.json...]")
    parser.add_argument("--out", required=True)
    parser.add_argument("--title", default="Hopper, one H100 (MuJoCo Warp): mean-policy return vs wall clock")
    args = parser.parse_args(argv)
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, spec in enumerate(args.series):
        label, _, files = spec.partition("=")
        rows = [row for f in files.split(",") for row in harness.rows_of(f)]
        for j, row in enumerate(rows):
            seconds = [h["seconds"] for h in row["history"]]
            returns = [h["return_mean_policy"] for h in row["history"]]
            ax.plot(seconds, returns, color=f"C{i}", alpha=0.8, label=label if j == 0 else None)
    ax.axhline(3000, color="gray", linestyle="--", linewidth=1)
    ax.set_xlabel("wall clock, seconds (compilation included)")
    ax.set_ylabel("mean-policy return (32 episodes)")
    ax.set_title(args.title, fontsize=10)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
