"""Sweeps of several tasks together: ``python -m jaxpg.sweep.aggregate DIR... --normalize TASK=LOW:HIGH``.

Each directory is a finished sweep of one task (``runs.csv``); configurations are matched across
tasks by their label (the swept values, e.g. ``lr=0.0003 clip_eps=0.2``). Scores are normalised per
task, ``(score - LOW) / (HIGH - LOW)`` (e.g. a random policy's and a reference score), and each
configuration's runs over all tasks give its mean, median and IQM with 95 % stratified-bootstrap
intervals (runs resampled within each task, ``jaxpg.sweep.stats``). Writes ``aggregate.csv``,
``profiles.csv`` and ``performance_profiles.png`` (the fraction of runs above each normalised score)
under ``--out``; ``--compare A B`` prints the probability that configuration A's runs beat B's.
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from jaxpg.sweep import stats


def read_scores(directory: Path) -> tuple[str, dict[str, list[float]]]:
    """``(task, {label: [score of each run]})`` of a finished sweep (its Gymnasium scores, or its
    final training returns where it scored none)."""
    import json

    summary = json.loads((directory / "summary.json").read_text())
    task = summary["spec"]["task"]
    scores: dict[str, list[float]] = {}
    for run in summary["runs"]:
        value = run["score"] if run["score"] is not None else run["final_return"]
        scores.setdefault(run["label"], []).append(float(value))
    return task, scores


def aggregate(directories: Sequence[Path], bounds: dict[str, tuple[float, float]]) -> dict[str, dict[str, list[float]]]:
    """``{label: {task: normalised scores}}`` for the configurations every sweep has."""
    per_task = dict(read_scores(Path(d)) for d in directories)
    missing = sorted(set(per_task) - set(bounds))
    if missing:
        raise ValueError(f"no --normalize bounds for {', '.join(missing)}")
    labels = set.intersection(*(set(s) for s in per_task.values()))
    if not labels:
        raise ValueError("the sweeps share no configuration (labels differ)")
    return {
        label: {task: list(stats.normalize(np.array(s[label]), *bounds[task])) for task, s in per_task.items()}
        for label in sorted(labels)
    }


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m jaxpg.sweep.aggregate", description=__doc__.splitlines()[0])
    p.add_argument("directories", nargs="+", type=Path)
    p.add_argument("--normalize", action="append", default=[], metavar="TASK=LOW:HIGH", required=True)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--compare", nargs=2, metavar=("A", "B"), default=None, help="P(A > B) of two labels")
    args = p.parse_args(argv)
    try:
        bounds = {}
        for text in args.normalize:
            task, _, span = text.partition("=")
            low, _, high = span.partition(":")
            bounds[task] = (float(low), float(high))
        table = aggregate(args.directories, bounds)
        if args.compare and any(label not in table for label in args.compare):
            raise ValueError(f"--compare: labels must be among {', '.join(table)}")
    except (ValueError, OSError, KeyError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    rows = [{"label": label, **stats.summarize(by_task)} for label, by_task in table.items()]
    with (args.out / "aggregate.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    thresholds = np.linspace(0.0, 1.5, 31)
    profiles = {label: stats.performance_profile(by_task, thresholds) for label, by_task in table.items()}
    with (args.out / "profiles.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["label", "threshold", "fraction", "low", "high"])
        for label, profile in profiles.items():
            writer.writerows([label, tau, *point] for tau, point in zip(thresholds, profile, strict=True))
    draw_profiles(profiles, thresholds, args.out / "performance_profiles.png")
    for row in sorted(rows, key=lambda r: -r["iqm"]):
        print(f"{row['label']:<40} IQM {row['iqm']:.3f} [{row['iqm_low']:.3f}, {row['iqm_high']:.3f}]")
    if args.compare:
        a, b = args.compare
        point, low, high = stats.probability_of_improvement(table[a], table[b])
        print(f"P({a} > {b}) = {point:.3f} [{low:.3f}, {high:.3f}]")
    return 0


def draw_profiles(profiles: dict[str, list], thresholds: np.ndarray, path: Path) -> None:
    """Each configuration's performance profile with its 95 % band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for label, profile in profiles.items():
        points = np.array(profile)
        ax.plot(thresholds, points[:, 0], label=label)
        ax.fill_between(thresholds, points[:, 1], points[:, 2], alpha=0.2)
    ax.set_xlabel("normalised score tau")
    ax.set_ylabel("fraction of runs with score > tau")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
