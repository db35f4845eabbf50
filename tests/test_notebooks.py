"""Every notebook under ``notebooks/`` runs top to bottom in quick mode (``JAXPG_QUICK=1``).

Each notebook is executed with nbclient on the ``python3`` kernel of the running interpreter, with
tiny settings; any error in any cell fails the test. Every notebook ends with a cell that asserts
its headline results (the pendulum or cart-pole learns, the loss decreases, the reloaded policy
acts as the trained one ...), so a tutorial whose results broke fails here too, not only one that
raises. Takes a few minutes on two CPU cores.
"""

from __future__ import annotations

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
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(
        nb,
        timeout=CELL_TIMEOUT_S,
        kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute()  # raises CellExecutionError on the first failing cell
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.output_type == "error"]
    assert not errors, f"{path.name}: {errors[0]['ename']}: {errors[0]['evalue']}"


def test_notebooks_exist():
    assert len(NOTEBOOKS) >= 4, [p.name for p in NOTEBOOKS]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_ends_with_its_checks(path):
    """The last code cell asserts the headline results; outputs stay stripped in the repository."""
    nb = nbformat.read(path, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert "assert " in code[-1].source, f"{path.name}: the last code cell asserts nothing"
    assert not any(c.get("outputs") for c in code), f"{path.name}: committed with outputs"
