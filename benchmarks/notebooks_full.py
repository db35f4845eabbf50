"""Run the notebooks with their default (full) settings and report what each printed.

CI runs every notebook in quick mode (``tests/test_notebooks.py``, ``JAXPG_QUICK=1``, on a copy);
this runs them as a reader would, without ``JAXPG_QUICK``, to check that the defaults reproduce the
result the notebook's text describes. Each executed notebook is written to ``--out`` (outputs kept
there, not in git), and the text each one printed is echoed with its wall-clock time.

``--in-place`` writes the executed notebooks back over ``notebooks/`` instead: that is how the
committed outputs are refreshed. The line of the first cell that starts with ``**Executed**`` is
then rewritten to say on what machine, with which JAX and MuJoCo, on which date and in how many
minutes it ran.

Every notebook it writes records what produced it in its metadata (``metadata["jaxpg_provenance"]``,
``provenance``): a sha256 of its code cells' sources, a sha256 of its outputs as a reader sees them
(stream text, every MIME type's data, errors; not execution counts, ids or output metadata), the
same two per code cell, and the library's git commit when it ran (``HEAD``, and whether ``jaxpg/``
had uncommitted changes). ``tests/test_notebooks.py`` recomputes the hashes and fails when a
committed notebook's code or outputs changed since. ``--stamp`` records it for the notebooks as
they are, without executing them, with the commit that introduced their outputs (from git history).

    python benchmarks/notebooks_full.py --out runs/notebooks-full                 # all of them
    python benchmarks/notebooks_full.py --out runs/notebooks-full 02 04           # by number
    python benchmarks/notebooks_full.py --in-place 03                             # refresh 03's outputs
    python benchmarks/notebooks_full.py --stamp                                   # record, not run
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import nbclient
import nbformat

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
STAMP = re.compile(r"^\*\*Executed\*\*.*$", re.MULTILINE)
PROVENANCE = "jaxpg_provenance"  # the notebook metadata key of ``provenance``


def printed_text(nb: nbformat.NotebookNode) -> list[str]:
    """The stream and plain-text outputs of every code cell, in order."""
    lines = []
    for cell in nb.cells:
        for out in cell.get("outputs", []) if cell.cell_type == "code" else []:
            if out.output_type == "stream":
                lines.extend(out.text.rstrip().splitlines())
            elif out.output_type == "execute_result" and "text/plain" in out.get("data", {}):
                lines.extend(out["data"]["text/plain"].rstrip().splitlines())
            elif out.output_type == "error":
                lines.append(f"ERROR {out.ename}: {out.evalue}")
    return lines


def machine() -> str:
    """``"2-core CPU (AMD EPYC ...), JAX 0.10.2 (cpu), MuJoCo/MJX 3.17.0"``: where the kernel ran."""
    import jax
    import mujoco

    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = " (" + line.split(":", 1)[1].strip() + ")"
                break
    except OSError:
        pass
    backend = jax.default_backend()
    where = f"{os.cpu_count()}-core CPU{model}"
    if backend != "cpu":
        where = f"{jax.devices()[0].device_kind}, {where}"
    return f"{where}, JAX {jax.__version__} ({backend}), MuJoCo/MJX {mujoco.__version__}"


def stamp(nb: nbformat.NotebookNode, seconds: float, where: str, date: str) -> bool:
    """Rewrite the first cell's ``**Executed**`` line; returns whether there was one."""
    first = nb.cells[0]
    line = f"**Executed** {date} in {seconds / 60:.0f} min (full mode: the notebook's defaults) on: {where}."
    first.source, count = STAMP.subn(line, first.source, count=1)
    return count == 1


def sha256_of(value: Any) -> str:
    """Hex sha256 of ``value`` (JSON data) written as canonical JSON: sorted keys, no spaces, UTF-8."""
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode()).hexdigest()


def visible_output(out: nbformat.NotebookNode) -> dict[str, Any]:
    """What a reader sees of one output: a stream's name and text; the data of every MIME type of a
    result or display (text/plain, image/png ...); an error's name, value and traceback. Execution
    counts, output metadata and display ids are left out: they change without the content."""
    if out.output_type == "stream":
        return {"type": "stream", "name": out.name, "text": out.text}
    if out.output_type == "error":
        return {"type": "error", "ename": out.ename, "evalue": out.evalue, "traceback": list(out.traceback)}
    return {"type": out.output_type, "data": dict(out.get("data", {}))}


def code_cells(nb: nbformat.NotebookNode) -> list[nbformat.NotebookNode]:
    """The notebook's code cells, in order."""
    return [cell for cell in nb.cells if cell.cell_type == "code"]


def content_digests(nb: nbformat.NotebookNode) -> dict[str, Any]:
    """``{"code_sha256", "outputs_sha256", "cells"}``: the sha256 of the code cells' sources (a list
    of strings), of their outputs (a list per cell of ``visible_output``), and per code cell
    ``{"code": sha256, "outputs": sha256}`` of the same, so that a difference can be placed."""
    sources = [cell.source for cell in code_cells(nb)]
    outputs = [[visible_output(out) for out in cell.get("outputs", [])] for cell in code_cells(nb)]
    return {
        "code_sha256": sha256_of(sources),
        "outputs_sha256": sha256_of(outputs),
        "cells": [
            {"code": sha256_of(src), "outputs": sha256_of(outs)} for src, outs in zip(sources, outputs, strict=True)
        ],
    }


def git(*args: str) -> str | None:
    """``git args...`` in the repository, its stripped stdout; ``None`` where git or the repository
    is missing or the command fails."""
    try:
        done = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def library_state() -> tuple[str | None, bool | None]:
    """``(HEAD's commit, whether jaxpg/ has uncommitted changes)``; ``(None, None)`` without git."""
    commit = git("rev-parse", "HEAD")
    status = git("status", "--porcelain", "--", "jaxpg") if commit else None
    return commit, (None if status is None else bool(status))


def provenance(nb: nbformat.NotebookNode, commit: str | None, modified: bool | None, recorded: str) -> dict[str, Any]:
    """The metadata that says what produced ``nb``'s outputs: ``content_digests`` of it as it is now,
    the library's commit and whether ``jaxpg/`` had uncommitted changes then, and how this was
    ``recorded`` ("after execution", or "stamped without executing" for ``--stamp``)."""
    return {"recorded": recorded, "library_commit": commit, "library_modified": modified, **content_digests(nb)}


def commit_of_outputs(path: Path) -> str | None:
    """The commit that introduced ``path``'s current outputs: from ``HEAD``'s last commit of the
    file, back through the commits that changed it (across merges: to whichever parent has the same
    outputs) while their version has the same outputs as the file now; the last one reached. ``None``
    without git or when the file's last commit has other outputs (uncommitted outputs)."""
    relative = path.resolve().relative_to(ROOT).as_posix()
    history = git("rev-list", "--parents", "HEAD", "--", relative)  # parents rewritten to commits of the file
    if not history:
        return None
    parents = {line.split()[0]: line.split()[1:] for line in history.splitlines()}
    wanted = content_digests(nbformat.read(path, as_version=4))["outputs_sha256"]

    def same_outputs(commit: str) -> bool:
        text = git("show", f"{commit}:{relative}")
        return text is not None and content_digests(nbformat.reads(text, as_version=4))["outputs_sha256"] == wanted

    commit = history.split()[0]
    if not same_outputs(commit):
        return None
    while True:
        earlier = [parent for parent in parents.get(commit, []) if parent in parents and same_outputs(parent)]
        if not earlier:
            return commit
        commit = earlier[0]


def stamp_provenance(path: Path) -> dict[str, Any]:
    """Record ``provenance`` in the notebook at ``path`` without executing it: its code and outputs as
    they are (so it vouches that the current code produced them), with the commit that introduced
    these outputs (``commit_of_outputs``) for the library's. A record that still matches the
    notebook is kept as it is. Rewrites only the metadata (through a temporary file, so that a
    failed write leaves the notebook whole); returns the record."""
    nb = nbformat.read(path, as_version=4)
    old = nb.metadata.get(PROVENANCE)
    digests = content_digests(nb)
    if old and all(old.get(key) == digests[key] for key in digests):
        return old
    record = provenance(nb, commit_of_outputs(path), None, "stamped without executing")
    nb.metadata[PROVENANCE] = record
    partial = path.with_name(path.name + ".partial")
    nbformat.write(nb, partial)
    os.replace(partial, path)
    return record


def strip_widget_state(nb: nbformat.NotebookNode) -> None:
    """Drop ipywidgets' saved state, which can be large and means nothing without a live kernel."""
    nb.metadata.pop("widgets", None)


def run(path: Path, out_path: Path, cell_timeout_s: int) -> float:
    """Execute one notebook in full mode into ``out_path``, with its ``provenance``; returns its
    wall-clock seconds."""
    commit, modified = library_state()  # the library that runs, before the run rewrites anything
    nb = nbformat.read(path, as_version=4)
    work = Path(tempfile.mkdtemp(prefix=f"jaxpg-{path.stem}-"))  # the kernel's working directory
    client = nbclient.NotebookClient(
        nb, timeout=cell_timeout_s, kernel_name="python3", resources={"metadata": {"path": str(work)}}
    )
    start = time.perf_counter()
    failed = True
    try:
        client.execute()
        failed = False
    finally:
        seconds = time.perf_counter() - start
        if failed and out_path == path:  # keep the committed notebook; the failed run goes beside the work
            out_path = work / path.name
        strip_widget_state(nb)
        if not stamp(nb, seconds, machine(), datetime.date.today().isoformat()):
            print(f"   ({path.name} has no **Executed** line to update)", flush=True)
        nb.metadata[PROVENANCE] = provenance(nb, commit, modified, "after execution")
        nbformat.write(nb, out_path)
        print(f"== {path.name}: {seconds:.0f} s -> {out_path} ({out_path.stat().st_size / 1e6:.2f} MB)", flush=True)
        for line in printed_text(nb):
            print(f"   {line}", flush=True)
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("numbers", nargs="*", help="notebook numbers (default: all)")
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--out", type=Path, help="where the executed notebooks go")
    where.add_argument("--in-place", action="store_true", help="overwrite notebooks/ with the executed notebooks")
    where.add_argument(
        "--stamp",
        action="store_true",
        help="record the provenance metadata of notebooks/ as they are, without executing them",
    )
    parser.add_argument("--cell-timeout", type=int, default=3600, help="seconds a cell may take")
    args = parser.parse_args()
    paths = sorted(NOTEBOOKS.glob("*.ipynb"))
    if args.numbers:
        paths = [p for p in paths if p.name.split("_")[0] in args.numbers]
    if args.stamp:
        for path in paths:
            record = stamp_provenance(path)
            print(f"== {path.name}: outputs of library commit {record['library_commit']}", flush=True)
        return
    os.environ.pop("JAXPG_QUICK", None)
    from jaxpg import video

    video.configure_gl()  # the kernels inherit MUJOCO_GL: a backend whose library loads, or none
    # The "python3" kernel spec starts `python`; put this interpreter's directory first.
    os.environ["PATH"] = str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", "")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    for path in paths:
        run(path, path if args.in_place else args.out / path.name, args.cell_timeout)


if __name__ == "__main__":
    main()
