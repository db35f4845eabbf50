"""Run the notebooks with their default (full) settings and report what each printed.

CI runs every notebook in quick mode (``tests/test_notebooks.py``, ``JAXPG_QUICK=1``); this runs
them as a reader would, without ``JAXPG_QUICK``, to check that the defaults reproduce the result
the notebook's text describes. Each executed notebook is written to ``--out`` (outputs kept there,
not in git), and the text each one printed is echoed with its wall-clock time.

    python benchmarks/notebooks_full.py --out runs/notebooks-full                 # all four
    python benchmarks/notebooks_full.py --out runs/notebooks-full 02 04           # by number
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import nbclient
import nbformat

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"


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


def run(path: Path, out_dir: Path, cell_timeout_s: int) -> float:
    """Execute one notebook in full mode; returns its wall-clock seconds."""
    nb = nbformat.read(path, as_version=4)
    work = out_dir / path.stem
    work.mkdir(parents=True, exist_ok=True)
    client = nbclient.NotebookClient(
        nb, timeout=cell_timeout_s, kernel_name="python3", resources={"metadata": {"path": str(work)}}
    )
    start = time.perf_counter()
    try:
        client.execute()
    finally:
        seconds = time.perf_counter() - start
        nbformat.write(nb, out_dir / path.name)
        print(f"== {path.name}: {seconds:.0f} s", flush=True)
        for line in printed_text(nb):
            print(f"   {line}", flush=True)
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("numbers", nargs="*", help="notebook numbers (default: all)")
    parser.add_argument("--out", type=Path, required=True, help="where the executed notebooks go")
    parser.add_argument("--cell-timeout", type=int, default=3600, help="seconds a cell may take")
    args = parser.parse_args()
    os.environ.pop("JAXPG_QUICK", None)
    from jaxpg import video

    video.configure_gl()  # the kernels inherit MUJOCO_GL: a backend whose library loads, or none
    # The "python3" kernel spec starts `python`; put this interpreter's directory first.
    os.environ["PATH"] = str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", "")
    paths = sorted(NOTEBOOKS.glob("*.ipynb"))
    if args.numbers:
        paths = [p for p in paths if p.name.split("_")[0] in args.numbers]
    args.out.mkdir(parents=True, exist_ok=True)
    for path in paths:
        run(path, args.out, args.cell_timeout)


if __name__ == "__main__":
    main()
