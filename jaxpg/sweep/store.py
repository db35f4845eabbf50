"""A sweep directory: the spec, one record per trained chunk, the scores, the tidy tables.

Layout:
  sweep.json                 the spec (``SweepSpec.to_json``) and its configurations; a resume
                             with another spec is refused
  chunks/chunk-NNNNN.npz     a chunk's learning curves and final policies (plain arrays)
  chunks/chunk-NNNNN.json    its runs and timings, written last: a chunk without it never finished
  chunks/chunk-NNNNN.scores.json   the Gymnasium scores of its runs
  runs.csv, curves.csv, configurations.csv, summary.json, figures/   (``jaxpg.sweep.report``)

Every file is written to a temporary name and renamed, so an interruption leaves whole files only.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg.sweep.runner import ChunkResult, Run
from jaxpg.sweep.spec import SpecError


def write_json(path: Path, data: Any) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True))
    os.replace(tmp, path)


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    tmp = path.with_name(path.name + ".tmp.npz")
    np.savez(tmp, **arrays)
    os.replace(tmp, path)


class SweepStore:
    """The sweep directory ``root`` (module docstring)."""

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)
        self.chunks = self.root / "chunks"

    def open(self, description: dict[str, Any]) -> None:
        """Create the directory for ``description`` (the spec and its configurations), or check
        that it already holds that sweep (``SpecError`` otherwise)."""
        path = self.root / "sweep.json"
        if path.exists():
            try:
                held = json.loads(path.read_text())
            except (OSError, json.JSONDecodeError) as e:
                raise SpecError(f"cannot read {path}: {e}") from None
            if held != json.loads(json.dumps(description, sort_keys=True)):
                raise SpecError(f"{self.root} holds another sweep; give a new output directory or the same spec")
            return
        if self.root.exists() and any(self.root.iterdir()):
            raise SpecError(f"{self.root} exists and is not a sweep directory")
        self.chunks.mkdir(parents=True, exist_ok=True)
        write_json(path, description)

    def chunk_names(self) -> list[str]:
        """Names of the finished chunks, in order."""
        if not self.chunks.is_dir():
            return []
        return sorted(p.name[: -len(".json")] for p in self.chunks.glob("chunk-*.json") if ".scores" not in p.name)

    def records(self) -> list[dict[str, Any]]:
        return [json.loads((self.chunks / f"{name}.json").read_text()) for name in self.chunk_names()]

    def finished_runs(self) -> set[int]:
        """Indices of the runs some finished chunk holds."""
        return {run for record in self.records() for run in record["runs"]}

    def save_chunk(self, result: ChunkResult) -> str:
        """Write ``result`` as the next chunk; returns its name."""
        name = f"chunk-{len(self.chunk_names()):05d}"
        arrays = {f"curve/{k}": v for k, v in result.curves.items()}
        arrays.update({f"params/{i}": x for i, x in enumerate(result.params)})
        arrays.update({f"obs_stats/{i}": x for i, x in enumerate(result.obs_stats)})
        arrays["wall_s"] = result.wall_s
        write_npz(self.chunks / f"{name}.npz", arrays)
        record = {
            "runs": [r.index for r in result.runs],
            "block": result.block,
            "compile_s": result.compile_s,
            "train_s": result.train_s,
        }
        write_json(self.chunks / f"{name}.json", record)
        return name

    def load_chunk(self, name: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """``(record, arrays)`` of chunk ``name``."""
        record = json.loads((self.chunks / f"{name}.json").read_text())
        with np.load(self.chunks / f"{name}.npz", allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        return record, arrays

    def scores(self, name: str) -> dict[str, float] | None:
        path = self.chunks / f"{name}.scores.json"
        return json.loads(path.read_text()) if path.exists() else None

    def save_scores(self, name: str, scores: dict[int, float]) -> None:
        write_json(self.chunks / f"{name}.scores.json", {str(k): v for k, v in scores.items()})


def leaves(arrays: dict[str, np.ndarray], prefix: str) -> list[np.ndarray]:
    """The ``prefix/0, prefix/1 ...`` arrays of a chunk, in order."""
    count = sum(1 for k in arrays if k.startswith(prefix + "/"))
    return [arrays[f"{prefix}/{i}"] for i in range(count)]


def run_rows(runs: list[Run]) -> dict[int, Run]:
    return {r.index: r for r in runs}
