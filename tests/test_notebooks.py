"""Every notebook under ``notebooks/`` runs top to bottom in quick mode (``JAXPG_QUICK=1``).

Each notebook is executed with nbclient on the ``python3`` kernel of the running interpreter, with
tiny settings; any error in any cell fails the test. Every notebook ends with a cell that asserts
its headline results (the pendulum or cart-pole learns, the loss decreases, the reloaded policy
acts as the trained one ...), so a tutorial whose results broke fails here too, not only one that
raises. Takes a few minutes on two CPU cores.

The committed notebooks carry the outputs of a full-mode run (``benchmarks/notebooks_full.py
--in-place``); the test executes a copy with those outputs cleared and never writes it back.
"""

from __future__ import annotations

import copy
import os
import sys
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

NOTEBOOKS = sorted((Path(__file__).parent.parent / "notebooks").glob("*.ipynb"))
CELL_TIMEOUT_S = 600


@pytest.fixture(scope="module")
def kernel_env():
    """Quick mode and offscreen rendering for the kernel; the kernel runs this interpreter."""
    saved = {k: os.environ.get(k) for k in ("JAXPG_QUICK", "MUJOCO_GL", "PATH")}
    os.environ["JAXPG_QUICK"] = "1"  # MUJOCO_GL: what conftest's jaxpg.video.configure_gl chose, if any
    # The "python3" kernel spec starts `python`; put this interpreter's directory first.
    os.environ["PATH"] = str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", "")
    yield
    for k, v in saved.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_in_quick_mode(path, kernel_env, tmp_path):
    committed = path.read_bytes()
    nb = copy.deepcopy(nbformat.read(path, as_version=4))
    for cell in nb.cells:  # the full-mode outputs must not pass for this run's
        if cell.cell_type == "code":
            cell.outputs, cell.execution_count = [], None
    client = nbclient.NotebookClient(
        nb,
        timeout=CELL_TIMEOUT_S,
        kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute()  # raises CellExecutionError on the first failing cell
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.output_type == "error"]
    assert not errors, f"{path.name}: {errors[0]['ename']}: {errors[0]['evalue']}"
    assert path.read_bytes() == committed, f"{path.name} was changed by its quick-mode run"


def test_notebooks_exist():
    assert len(NOTEBOOKS) >= 4, [p.name for p in NOTEBOOKS]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_ends_with_its_checks(path):
    """The last code cell asserts the headline results."""
    nb = nbformat.read(path, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert "assert " in code[-1].source, f"{path.name}: the last code cell asserts nothing"


MAX_NOTEBOOK_BYTES = 2_000_000


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_is_committed_executed(path):
    """Committed with the outputs of one full run, top to bottom, in full mode and without errors;
    small (no widget state), and its first cell says where and when it ran (``**Executed**``)."""
    nb = nbformat.read(path, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    counts = [c.get("execution_count") for c in code]
    assert counts == list(range(1, len(code) + 1)), f"{path.name}: not executed top to bottom: {counts}"
    outputs = [o for c in code for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"], f"{path.name}: committed with an error"
    printed = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    assert "full mode" in printed and "quick mode" not in printed, f"{path.name}: not a full-mode run"
    assert "all checks passed" in printed, f"{path.name}: its checks did not pass"
    assert "widgets" not in nb.metadata, f"{path.name}: widget state committed"
    assert path.stat().st_size < MAX_NOTEBOOK_BYTES, f"{path.name}: {path.stat().st_size} bytes"
    assert "**Executed** 20" in nb.cells[0].source, f"{path.name}: the first cell does not say when it ran"
