"""Run the notebooks with their default (full) settings and report what each printed.

CI runs every notebook in quick mode (``tests/test_notebooks.py``, ``JAXPG_QUICK=1``, on a copy);
this runs them as a reader would, without ``JAXPG_QUICK``, to check that the defaults reproduce the
result the notebook's text describes. Each executed notebook is written to ``--out`` (outputs kept
there, not in git), and the text each one printed is echoed with its wall-clock time.

``--in-place`` writes the executed notebooks back over ``notebooks/`` instead: that is how the
committed outputs are refreshed. The line of the first cell that starts with ``**Executed**`` is
then rewritten to say on what machine, with which JAX and MuJoCo, on which date and in how many
minutes it ran.

    python benchmarks/notebooks_full.py --out runs/notebooks-full                 # all five
    python benchmarks/notebooks_full.py --out runs/notebooks-full 02 04           # by number
    python benchmarks/notebooks_full.py --in-place 03                             # refresh 03's outputs
"""

from __future__ import annotations

import argparse
import datetime
import os
import re
import sys
import tempfile
import time
from pathlib import Path

import nbclient
import nbformat

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
STAMP = re.compile(r"^\*\*Executed\*\*.*$", re.MULTILINE)


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


def strip_widget_state(nb: nbformat.NotebookNode) -> None:
    """Drop ipywidgets' saved state, which can be large and means nothing without a live kernel."""
    nb.metadata.pop("widgets", None)


def run(path: Path, out_path: Path, cell_timeout_s: int) -> float:
    """Execute one notebook in full mode into ``out_path``; returns its wall-clock seconds."""
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
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    for path in paths:
        run(path, path if args.in_place else args.out / path.name, args.cell_timeout)


if __name__ == "__main__":
    main()
