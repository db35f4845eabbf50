"""``metrics.jsonl`` and TensorBoard: one record per iteration and seed, written, read back and
truncated on resume; the score a checkpoint is ranked by."""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg.run import tensorboard
from jaxpg.run.layout import METRICS_FILE, TENSORBOARD_DIR
from jaxpg.run.tensorboard import EventWriter

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


class MetricsWriter:
    """Appends records to ``metrics.jsonl`` and the same scalars to TensorBoard event files
    (``jaxpg.run.tensorboard``).

    TensorBoard gets one sub-directory per seed (``tensorboard/seed_<s>``), scalars keyed by the
    metric name against the iteration; NaN (not measured) is skipped. ``start_iteration`` > 0
    (a resumed run) purges events the interrupted run wrote after that iteration.
    """

    def __init__(
        self,
        run_dir: str | os.PathLike,
        seeds: Sequence[int],
        start_iteration: int = 0,
        tensorboard: bool = True,
    ):
        self.run_dir = Path(run_dir)
        self.seeds = list(seeds)
        self._file = (self.run_dir / METRICS_FILE).open("a")
        self._writers: dict[int, EventWriter] = {}
        if tensorboard:
            purge = start_iteration + 1 if start_iteration > 0 else None
            for seed in self.seeds:
                logdir = self.run_dir / TENSORBOARD_DIR / f"seed_{seed}"
                self._writers[seed] = EventWriter(logdir, purge_step=purge)

    def write(self, records: Sequence[dict[str, Any]]) -> None:
        """Append ``records`` (``block_records``); TensorBoard gets one event per record holding
        its scalars, the events of all seeds framed together (``tensorboard.records``)."""
        seeds, events, now = [], [], time.time()
        for record in records:
            self._file.write(json.dumps(record) + "\n")
            if record["seed"] not in self._writers:
                continue
            # A non-finite value ("nan", "inf" in the record) is a float for TensorBoard.
            scalars = {k: float(v) for k, v in record.items() if k not in ("iteration", "seed") and v is not None}
            seeds.append(record["seed"])
            events.append(tensorboard.event(now, record["iteration"], summary=tensorboard.scalars_summary(scalars)))
        for seed, framed in zip(seeds, tensorboard.records(events), strict=True):
            self._writers[seed].write_records([framed])
        self._file.flush()
        for writer in self._writers.values():
            writer.flush()

    def add_text(self, tag: str, text: str) -> None:
        for writer in self._writers.values():
            writer.add_text(tag, text, step=0)

    def close(self) -> None:
        self._file.close()
        for writer in self._writers.values():
            writer.close()


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
