"""``metrics.jsonl``: one record per iteration and seed, written (the sink ``JsonlLog``), read back
and truncated on resume; the score a checkpoint is ranked by."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg.run.outputs.sink import Block, Entry, Sink
from jaxpg.run.rundir.layout import METRICS_FILE

# Keys every record starts with, in this order; the algorithm's diagnostics follow sorted.
LEADING_KEYS = (
    "iteration",
    "seed",
    "env_steps",
    "wall_time_s",
    "return_stochastic",
    "return_mean_policy",
    "episode_length",
    "task_score",
    "task_score_mean_policy",
)


# Metrics that are NaN when nothing was measured, and the metric that says whether it was: the
# mean policy's (not evaluated that iteration), and the episodes' (none ended in the iteration).
MEASURED_BY = {
    "return_mean_policy": "evaluated",
    "episode_length_mean_policy": "evaluated",
    "task_score_mean_policy": "evaluated",
    "return_stochastic": "episodes",
    "episode_length": "episodes",
    "task_score": "episodes",
}


def _scalar(x: Any, measured: bool = True) -> float | str | None:
    """A JSON value of a metric: a number; ``null`` when it was not measured; a measured value
    that is not finite as the string ``"nan"``, ``"inf"`` or ``"-inf"`` (``float`` reads them
    back), so that a diverged value is never mistaken for a missing one."""
    value = float(x)
    if math.isfinite(value):
        return value
    if not measured:
        return None
    return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")


def _measured(metrics: dict[str, np.ndarray], key: str, i: int, s: int, several: bool) -> bool:
    """Whether ``key`` was measured at row ``i`` (seed column ``s``): ``MEASURED_BY``'s gate is
    present and non-zero; metrics without a gate always are."""
    gate = MEASURED_BY.get(key)
    if gate is None:
        return True
    if gate not in metrics:
        return False
    value = metrics[gate][i, s] if several else metrics[gate][i]
    return bool(float(value) > 0)


def block_length(metrics: dict[str, np.ndarray]) -> int:
    """How many iterations a block of ``metrics`` holds (each array's leading axis)."""
    return len(next(iter(metrics.values())))


def block_records(
    metrics: dict[str, np.ndarray], first_iteration: int, seeds: Sequence[int], wall_times: Sequence[float]
) -> list[dict[str, Any]]:
    """One record per iteration (and seed) of a block of ``update`` metrics.

    ``metrics`` holds ``[n]`` arrays, or ``[n, num_seeds]`` when several seeds train together;
    ``wall_times[i]`` is the run's wall time at the end of the block's i-th iteration.
    """
    n = block_length(metrics)
    several = len(seeds) > 1
    keys = [k for k in LEADING_KEYS if k in metrics] + sorted(k for k in metrics if k not in LEADING_KEYS)
    records = []
    for i in range(n):
        for s, seed in enumerate(seeds):
            record: dict[str, Any] = {"iteration": first_iteration + i + 1, "seed": int(seed)}
            if "env_steps" in metrics:
                record["env_steps"] = _scalar(metrics["env_steps"][i, s] if several else metrics["env_steps"][i])
            record["wall_time_s"] = round(float(wall_times[i]), 4)
            for key in keys:
                if key not in record:
                    value = metrics[key][i, s] if several else metrics[key][i]
                    record[key] = _scalar(value, _measured(metrics, key, i, s, several))
            records.append(record)
    return records


# Metric names that earlier versions wrote -> the current ones (read_metrics renames them).
OLD_METRIC_NAMES = {
    "eval_metric": "task_score",
    "eval_metric_mean_policy": "task_score_mean_policy",
    "step_size": "step_length",
}


def read_metrics(path: str | os.PathLike) -> list[dict[str, Any]]:
    """The records of a ``metrics.jsonl`` (a torn last line, from a killed process, is skipped),
    with metric names of earlier versions renamed (``OLD_METRIC_NAMES``)."""
    path = Path(path)
    if path.is_dir():
        path = path / METRICS_FILE
    records = []
    if not path.exists():
        return records
    with path.open() as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue
            if not isinstance(record, dict):
                continue
            records.append({OLD_METRIC_NAMES.get(k, k): v for k, v in record.items()})
    return records


def damaged_metrics_line(path: str | os.PathLike) -> int | None:
    """The number (from 1) of the first line of a ``metrics.jsonl`` that is not a JSON object,
    blank lines and a torn last line (no newline at its end: a process killed while writing it)
    aside; ``None`` when every line reads."""
    with Path(path).open("rb") as f:
        lines = f.read().split(b"\n")
    # The piece after the last newline is a torn line (or empty): a resume drops it.
    for number, line in enumerate(lines[:-1], start=1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except ValueError:  # JSONDecodeError, or bytes that are not UTF-8
            return number
        if not isinstance(record, dict):
            return number
    return None


def truncate_metrics(run_dir: str | os.PathLike, last_iteration: int) -> float:
    """Drop the records after ``last_iteration`` (iterations a resumed run will redo).

    Returns the wall time of the last kept record (0 when none), so that a resumed run's
    ``wall_time_s`` continues from there.
    """
    path = Path(run_dir) / METRICS_FILE
    records = [r for r in read_metrics(path) if r.get("iteration", 0) <= last_iteration]
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w") as f:
        for r in records:
            f.write(json.dumps(r) + "\n")
    os.replace(tmp, path)
    return max((r.get("wall_time_s") or 0.0 for r in records), default=0.0)


class JsonlLog(Sink):
    """The sink of ``metrics.jsonl``: appends each block's records, one JSON object a line."""

    entries = (Entry(METRICS_FILE, temporary=(METRICS_FILE + ".tmp",)),)  # the temporary: truncate_metrics

    def __init__(self, run_dir: str | os.PathLike):
        self.run_dir = Path(run_dir)
        self._file = (self.run_dir / METRICS_FILE).open("a")

    @classmethod
    def open(cls, plan: Any, printer: Any) -> JsonlLog:
        return cls(plan.run_dir)

    def write_block(self, block: Block) -> None:
        self.write(block.records)

    def write(self, records: Sequence[dict[str, Any]]) -> None:
        """Append ``records`` (``block_records``) and flush."""
        for record in records:
            self._file.write(json.dumps(record) + "\n")
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def latest_value(values: np.ndarray) -> float:
    """The last measured (non-NaN) value of a block, averaged over seeds."""
    values = np.asarray(values, np.float64)
    rows = values.reshape(len(values), -1)
    for row in rows[::-1]:
        if not np.all(np.isnan(row)):
            return float(np.nanmean(row))
    return math.nan


def checkpoint_score(metrics: dict[str, np.ndarray], evaluated: bool) -> float:
    """The score a checkpoint saved after a block is ranked by for "best", one kind per run so that
    like is compared with like: when the run evaluates its mean policy (``evaluated``: eval_envs >
    0), the ``return_mean_policy`` of the block's last iteration (the checkpoint's), ``-inf`` when
    that iteration was not evaluated; otherwise the latest measured ``return_stochastic`` of the
    block. Means over seeds; ``-inf`` when nothing was measured."""
    if evaluated:
        if "return_mean_policy" not in metrics:
            return -math.inf
        last = np.asarray(metrics["return_mean_policy"], np.float64)[-1:]
        value = latest_value(last)
    else:
        value = latest_value(metrics["return_stochastic"]) if "return_stochastic" in metrics else math.nan
    return -math.inf if math.isnan(value) else value


def latest_score(metrics: dict[str, np.ndarray]) -> float:
    """The score a checkpoint is ranked by: the latest measured ``return_mean_policy`` of the
    block (mean over seeds), falling back to ``return_stochastic``; ``-inf`` when neither was."""
    for key in ("return_mean_policy", "return_stochastic"):
        if key in metrics:
            value = latest_value(metrics[key])
            if not math.isnan(value):
                return value
    return -math.inf
