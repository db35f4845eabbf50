"""Sweep two fields of PPO on Walker2d with 8 seeds, print the IQM table, draw the figures.

Two learning rates x two entropy bonuses of the ``walker2d_fast`` preset, 8 seeds each: 32 runs in
one compiled program (both fields are traced hyperparameters), scored in Gymnasium's Walker2d-v5,
reported with 95 % stratified-bootstrap intervals (docs/sweeps.md). Run it again with the same
``--out`` to resume after an interruption.

    python experiments/sweep_walker2d.py --out sweeps/walker2d-ppo
    python experiments/sweep_walker2d.py --out /tmp/w --iterations 2 --seeds 2 --episodes 1   # a smoke run
"""

from __future__ import annotations

import argparse
import sys

from jaxpg.sweep import SpecError, SweepSpec, run_sweep, stats


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="the sweep directory (created, or resumed)")
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--iterations", type=int, default=None, help="default: the preset's")
    parser.add_argument("--episodes", type=int, default=10, help="Gymnasium episodes per run's score")
    args = parser.parse_args(argv)
    spec = SweepSpec(
        task="walker2d",
        algo="ppo",
        preset="walker2d_fast",
        grid={"lr": [1e-4, 3e-4], "entropy_coef": [0.0, 1e-3]},
        seeds=tuple(range(args.seeds)),
        iterations=args.iterations,
    )
    try:
        report = run_sweep(spec, args.out, episodes=args.episodes)
    except SpecError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if report is None:
        return 0
    print(report.table())
    # Probability that the best configuration's runs beat the runner-up's, with its interval.
    ranked = sorted(report.configurations, key=lambda row: -row["iqm"])
    key = ranked[0]["scored_by"]
    scores = {
        row["configuration"]: [r[key] for r in report.runs if r["configuration"] == row["configuration"]]
        for row in ranked[:2]
    }
    if len(ranked) > 1:
        best, second = ranked[0]["configuration"], ranked[1]["configuration"]
        p, low, high = stats.probability_of_improvement({"walker2d": scores[best]}, {"walker2d": scores[second]})
        print(f"P({ranked[0]['label']} > {ranked[1]['label']}) = {p:.2f} [{low:.2f}, {high:.2f}]")
    print(f"tables: {args.out}/configurations.csv, runs.csv, curves.csv; figures: {args.out}/figures/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
