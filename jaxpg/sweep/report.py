"""A finished sweep as tables, statistics and figures (``SweepReport``), from its directory.

Tables (tidy CSV, one observation a row): ``runs.csv`` (one row per run: configuration, seed,
swept values, ``score`` in Gymnasium, ``final_return`` the mean training return over the last
tenth of its iterations, training seconds), ``curves.csv`` (one row per run and iteration:
env steps, wall-clock seconds, training return), ``configurations.csv`` (one row per
configuration: mean, median and IQM of its runs' scores over seeds with 95 % bootstrap intervals,
``jaxpg.sweep.stats``); ``summary.json`` holds all three and the timings.

A run's wall clock is its chunk's (all runs of a chunk train together), measured at the end of
each block of iterations and interpolated linearly within a block.

Figures (``figures/``): training return against env steps and against wall-clock seconds per
configuration (IQM over seeds, 95 % interval band; the ``plots.MAX_CURVES`` best configurations by IQM
score), and one sensitivity plot per swept field (each configuration's IQM score and interval
against the field's value).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg.sweep import stats
from jaxpg.sweep.runner import Run
from jaxpg.sweep.spec import Configuration, SweepSpec
from jaxpg.sweep.store import SweepStore


@dataclasses.dataclass
class SweepReport:
    """A finished sweep (module docstring). ``runs`` and ``configurations`` are lists of rows
    (dicts); ``curves`` maps a run index to ``{"env_steps", "wall_s", "return"}`` arrays
    ``[iterations]``; ``timing`` the chunks' compile and training seconds."""

    spec: SweepSpec
    runs: list[dict[str, Any]]
    configurations: list[dict[str, Any]]
    curves: dict[int, dict[str, np.ndarray]]
    timing: dict[str, float]
    swept: list[str]

    def table(self) -> str:
        """The configurations as a text table, best IQM first."""
        rows = sorted(self.configurations, key=lambda r: -r["iqm"] if math.isfinite(r["iqm"]) else math.inf)
        lines = [f"{'configuration':<40} {'runs':>4} {'IQM [95% CI]':>28} {'median':>10} {'mean':>10}"]
        for r in rows:
            ci = f"{r['iqm']:.1f} [{r['iqm_low']:.1f}, {r['iqm_high']:.1f}]"
            lines.append(f"{r['label']:<40} {int(r['runs']):>4} {ci:>28} {r['median']:>10.1f} {r['mean']:>10.1f}")
        return "\n".join(lines)

    def write(self, root: Path, figures: bool = True) -> None:
        """The tables, ``summary.json`` and (with ``figures``) the figures under ``root``."""
        _write_csv(root / "runs.csv", self.runs)
        _write_csv(root / "configurations.csv", self.configurations)
        rows = []
        for run in self.runs:
            curve = self.curves[run["run"]]
            for i in range(len(curve["return"])):
                rows.append(
                    {
                        "run": run["run"],
                        "configuration": run["configuration"],
                        "seed": run["seed"],
                        "iteration": i + 1,
                        "env_steps": float(curve["env_steps"][i]),
                        "wall_s": round(float(curve["wall_s"][i]), 4),
                        "return": float(curve["return"][i]),
                    }
                )
        _write_csv(root / "curves.csv", rows)
        summary = {
            "spec": self.spec.to_json(),
            "configurations": self.configurations,
            "runs": self.runs,
            "timing": self.timing,
        }
        (root / "summary.json").write_text(json.dumps(summary, indent=1, default=_json_default))
        if figures:
            from jaxpg.sweep import plots

            plots.draw(self, root / "figures")


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} as JSON")


def _write_csv(path: Path, rows: list[dict[str, Any]]) -> None:
    if not rows:
        path.write_text("")
        return
    names = list(rows[0])
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, names)
        writer.writeheader()
        writer.writerows(rows)


def final_return(curve: np.ndarray) -> float:
    """Mean training return over the last tenth (at least one) of the iterations."""
    tail = max(1, len(curve) // 10)
    return float(np.mean(curve[-tail:]))


def iteration_wall(wall_s: np.ndarray, block: int, iterations: int) -> np.ndarray:
    """``[iterations]`` wall-clock seconds at each iteration's end, interpolated linearly between
    the block ends ``wall_s`` (the chunk's start is 0 s)."""
    ends = np.arange(1, len(wall_s) + 1) * block
    return np.interp(np.arange(1, iterations + 1), np.concatenate([[0], ends]), np.concatenate([[0.0], wall_s]))


def build(store: SweepStore, spec: SweepSpec, configurations: list[Configuration], runs: list[Run]) -> SweepReport:
    """The report of the finished sweep in ``store``."""
    by_run = {r.index: r for r in runs}
    by_config = {c.index: c for c in configurations}
    swept = [*spec.grid, *spec.ranges]
    rows: dict[int, dict[str, Any]] = {}
    curves: dict[int, dict[str, np.ndarray]] = {}
    compile_s = train_s = 0.0
    for name in store.chunk_names():
        record, arrays = store.load_chunk(name)
        scores = store.scores(name) or {}
        compile_s += record["compile_s"]
        train_s += record["train_s"]
        returns = arrays["curve/return_stochastic"]
        iterations = returns.shape[1]
        wall = iteration_wall(arrays["wall_s"], record["block"], iterations)
        for row, index in enumerate(record["runs"]):
            run = by_run[index]
            config = by_config[run.configuration]
            steps = np.arange(1, iterations + 1) * float(config.config.samples_per_iteration)
            curves[index] = {"env_steps": steps, "wall_s": wall, "return": returns[row]}
            score = scores.get(str(index))
            rows[index] = {
                "run": index,
                "configuration": run.configuration,
                "seed": run.seed,
                "label": config.label,
                **config.values,
                "score": score,
                "final_return": final_return(returns[row]),
                "env_steps": float(steps[-1]),
                "train_s": record["train_s"] / len(record["runs"]),
            }
    run_rows = [rows[i] for i in sorted(rows)]
    scored = all(r["score"] is not None for r in run_rows)
    key = "score" if scored else "final_return"
    config_rows = []
    for c in configurations:
        values = [r[key] for r in run_rows if r["configuration"] == c.index]
        config_rows.append(
            {
                "configuration": c.index,
                "label": c.label,
                **c.values,
                "scored_by": key,
                **stats.summarize({spec.task: values}, seed=c.index),
            }
        )
    timing = {"compile_s": compile_s, "train_s": train_s, "runs": float(len(run_rows))}
    return SweepReport(spec, run_rows, config_rows, curves, timing, swept)
