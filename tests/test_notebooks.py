"""Every notebook under ``notebooks/`` runs top to bottom in quick mode (``JAXPG_QUICK=1``).

Each notebook is executed with nbclient on the ``python3`` kernel of the running interpreter, with
tiny settings; any error in any cell fails the test. Every notebook ends with a cell that asserts
its headline results (the pendulum or cart-pole learns, the loss decreases, the reloaded policy
acts as the trained one ...), so a tutorial whose results broke fails here too, not only one that
raises. Takes a few minutes on two CPU cores.

The committed notebooks carry the outputs of a full-mode run (``benchmarks/notebooks_full.py
--in-place``); the test executes a copy with those outputs cleared and never writes it back. That
run records in each notebook's metadata a sha256 of its code cells and of its outputs (and the
library's commit); ``test_notebook_is_what_its_recorded_run_produced`` recomputes both, so that a
committed output edited by hand, or code changed without re-executing, fails and is named.
"""

from __future__ import annotations

import ast
import copy
import os
import shutil
import sys
from pathlib import Path

import pytest
from script_loader import ROOT, load_script

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

notebooks_full = load_script("benchmarks/notebooks_full.py")

NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
CELL_TIMEOUT_S = 600


@pytest.fixture(scope="module")
def kernel_env():
    """Quick mode and offscreen rendering for the kernel; the kernel runs this interpreter, with the
    XLA compile options conftest.py gives every test process (they decide how XLA:CPU generates
    code, not what it computes). Alone on two cores, notebook 05 ran in 91 s against 145 s with XLA's
    defaults, and notebook 01 in 95 s against 143 s."""
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


def is_check(statement: ast.stmt) -> bool:
    """An ``assert`` of something other than a constant, or a call of an ``assert...`` function
    (``np.testing.assert_allclose(...)``) as a statement."""
    if isinstance(statement, ast.Assert):
        return not isinstance(statement.test, ast.Constant)
    if isinstance(statement, ast.Expr) and isinstance(statement.value, ast.Call):
        func = statement.value.func
        name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
        return name.startswith("assert")
    return False


def unconditional_checks(statements: list[ast.stmt]) -> list[ast.stmt]:
    """The checks (``is_check``) among ``statements`` and in the bodies of their loops and ``with``
    blocks, not those under an ``if`` (such as the full-mode-only ``if not QUICK:``)."""
    found = []
    for statement in statements:
        if is_check(statement):
            found.append(statement)
        elif isinstance(statement, ast.For | ast.While | ast.With):
            found.extend(unconditional_checks(statement.body))
    return found


def prints_all_checks_passed(statement: ast.stmt) -> bool:
    """``print("all checks passed...")`` (a plain or f-string)."""
    if not (isinstance(statement, ast.Expr) and isinstance(statement.value, ast.Call)):
        return False
    call = statement.value
    if not (isinstance(call.func, ast.Name) and call.func.id == "print" and call.args):
        return False
    first = call.args[0]
    if isinstance(first, ast.JoinedStr) and first.values:
        first = first.values[0]
    return isinstance(first, ast.Constant) and str(first.value).startswith("all checks passed")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_ends_with_its_checks(path):
    """The last code cell asserts the headline results: its code holds assert statements (or
    ``assert_...`` calls) that run in every mode, and it ends by printing "all checks passed", the
    line that ``test_notebook_is_committed_executed`` looks for in the full-mode outputs."""
    nb = nbformat.read(path, as_version=4)
    last = notebooks_full.code_cells(nb)[-1]
    tree = ast.parse(last.source)
    assert unconditional_checks(tree.body), f"{path.name}: the last code cell asserts nothing in every mode"
    assert tree.body and prints_all_checks_passed(tree.body[-1]), (
        f"{path.name}: the last code cell does not end with print('all checks passed ...')"
    )


def test_notebook_check_recognises_only_real_checks():
    """A comment, a string or a constant that mentions assert is no check; an assert under an ``if``
    does not run in every mode; ``print`` of the line must be the last statement."""
    code = '# assert the result\nx = "assert x"\nassert True\nif not QUICK:\n    assert x\nprint("all checks passed")\n'
    assert not unconditional_checks(ast.parse(code).body)
    code = 'for r in rs:\n    assert r > 0\nnp.testing.assert_allclose(a, b)\nprint(f"all checks passed in {t}")\n'
    tree = ast.parse(code)
    assert len(unconditional_checks(tree.body)) == 2 and prints_all_checks_passed(tree.body[-1])
    assert not prints_all_checks_passed(ast.parse('print("all checks passed")\nx = 1\n').body[-1])


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


def changed_cells(recorded: dict, now: dict, nb: nbformat.NotebookNode) -> list[str]:
    """What differs between a notebook's recorded digests (``notebooks_full.content_digests`` at its
    run) and ``now``'s: ``["code of cells 3, 5", "outputs of cell 7"]``, cells numbered as a reader
    counts them (1-based, markdown cells included); ``[]`` when both hashes match."""
    changes = []
    if len(recorded["cells"]) != len(now["cells"]):
        changes.append(f"{len(recorded['cells'])} code cells at its run, {len(now['cells'])} now")
    numbers = [i + 1 for i, cell in enumerate(nb.cells) if cell.cell_type == "code"]
    for part in ("code", "outputs"):
        differ = [
            n for n, was, new in zip(numbers, recorded["cells"], now["cells"], strict=False) if was[part] != new[part]
        ]
        if differ:
            changes.append(f"{part} of cell{'s' if len(differ) > 1 else ''} {', '.join(map(str, differ))}")
        elif recorded[f"{part}_sha256"] != now[f"{part}_sha256"] and len(recorded["cells"]) == len(now["cells"]):
            changes.append(f"{part} (whole-notebook hash only)")
    return changes


def library_moved_since(commit: str | None) -> str:
    """How far the library has moved since ``commit``, in words, from ``git rev-list --count``."""
    if commit is None:
        return "its run recorded no library commit"
    if shutil.which("git") is None:
        return f"its run was at library commit {commit[:12]}; git is not available to count the commits since"
    count = notebooks_full.git("rev-list", "--count", f"{commit}..HEAD")
    if count is None:
        return f"its run was at library commit {commit[:12]}, which is not in this clone's history"
    in_library = notebooks_full.git("rev-list", "--count", f"{commit}..HEAD", "--", "jaxpg")
    return (
        f"its run was at library commit {commit[:12]}; the repository has moved {count} commits since "
        f"({in_library} of them change jaxpg/)"
    )


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_is_what_its_recorded_run_produced(path):
    """The code cells and the outputs a reader sees are those that the run recorded in the metadata
    (``benchmarks/notebooks_full.py``): both sha256 recomputed from the notebook as committed."""
    nb = nbformat.read(path, as_version=4)
    recorded = nb.metadata.get(notebooks_full.PROVENANCE)
    assert recorded, (
        f"{path.name}: no {notebooks_full.PROVENANCE} metadata; "
        f"re-execute it: python benchmarks/notebooks_full.py --in-place {path.name[:2]}"
    )
    changes = changed_cells(recorded, notebooks_full.content_digests(nb), nb)
    assert not changes, (
        f"{path.name}: {'; '.join(changes)} changed since the run that produced its outputs "
        f"({library_moved_since(recorded.get('library_commit'))}); "
        f"re-execute it: python benchmarks/notebooks_full.py --in-place {path.name[:2]}"
    )


def test_recorded_digests_place_every_visible_edit():
    """On a committed notebook and copies edited as a hand edit would: one digit of a printed number,
    one character of a PNG, one character of code, each found in its cell and nowhere else; what a
    reader does not see (execution counts, output and cell metadata, markdown) changes nothing."""
    nb = nbformat.read(ROOT / "notebooks" / "02_reinforce_pendulum.ipynb", as_version=4)
    recorded = notebooks_full.content_digests(nb)
    number = {i + 1: cell for i, cell in enumerate(nb.cells)}
    with_digit = next(
        n
        for n, cell in number.items()
        if cell.cell_type == "code"
        and any(o.output_type == "stream" and any(ch.isdigit() for ch in o.text) for o in cell.outputs)
    )
    with_png = next(
        n
        for n, cell in number.items()
        if cell.cell_type == "code" and any("image/png" in o.get("data", {}) for o in cell.outputs)
    )
    assert not changed_cells(recorded, notebooks_full.content_digests(nb), nb)

    def edited(cell_number: int, edit) -> list[str]:
        copy_ = copy.deepcopy(nb)
        edit(copy_.cells[cell_number - 1])
        return changed_cells(recorded, notebooks_full.content_digests(copy_), copy_)

    def bump_digit(cell: nbformat.NotebookNode) -> None:
        out = next(o for o in cell.outputs if o.output_type == "stream" and any(ch.isdigit() for ch in o.text))
        i = next(i for i, ch in enumerate(out.text) if ch.isdigit())
        out.text = out.text[:i] + str((int(out.text[i]) + 1) % 10) + out.text[i + 1 :]

    def flip_png(cell: nbformat.NotebookNode) -> None:
        out = next(o for o in cell.outputs if "image/png" in o.get("data", {}))
        png = out.data["image/png"]
        out.data["image/png"] = png[:100] + ("A" if png[100] != "A" else "B") + png[101:]

    def invisible(cell: nbformat.NotebookNode) -> None:
        cell.metadata["tags"] = ["edited"]
        if cell.cell_type == "code":
            cell.execution_count = 99
            for out in cell.outputs:
                out.setdefault("metadata", {})["edited"] = True
        else:
            cell.source += "\nedited"

    assert edited(with_digit, bump_digit) == [f"outputs of cell {with_digit}"]
    assert edited(with_png, flip_png) == [f"outputs of cell {with_png}"]
    assert edited(with_png, lambda cell: setattr(cell, "source", cell.source + " ")) == [f"code of cell {with_png}"]
    for n in number:
        assert edited(n, invisible) == [], n


def test_full_mode_run_records_the_digests_of_what_it_wrote(kernel_env, tmp_path):
    """``notebooks_full.run`` executes a notebook and records, after the execution, the digests of
    the code and outputs it writes and the repository's ``HEAD``: the committed notebooks' check
    then holds for what it wrote, and the recorded outputs are the executed ones, not the empty
    ones it read."""
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_markdown_cell("# t\n\n**Executed** never."),
        nbformat.v4.new_code_cell("print(6 * 7)"),
        nbformat.v4.new_code_cell("6 * 7"),
    ]
    source, written = tmp_path / "nb.ipynb", tmp_path / "out" / "nb.ipynb"
    written.parent.mkdir()
    nbformat.write(nb, source)
    notebooks_full.run(source, written, CELL_TIMEOUT_S)
    out = nbformat.read(written, as_version=4)
    recorded = out.metadata[notebooks_full.PROVENANCE]
    assert out.cells[1].outputs[0].text == "42\n" and out.cells[2].outputs[0].data["text/plain"] == "42"
    assert recorded["recorded"] == "after execution"
    assert not changed_cells(recorded, notebooks_full.content_digests(out), out)
    assert recorded["outputs_sha256"] != notebooks_full.content_digests(nb)["outputs_sha256"]
    assert recorded["library_commit"] == notebooks_full.git("rev-parse", "HEAD")


def test_stamp_finds_the_commit_that_introduced_the_outputs(tmp_path, monkeypatch):
    """``--stamp``'s ``commit_of_outputs``, in a repository made here: outputs executed on a branch
    and merged, then code edited on top; the commit is the branch's that changed the outputs, not
    the merge or the code edit after it, nor the earlier outputs' commit. Uncommitted outputs have
    none."""
    monkeypatch.setattr(notebooks_full, "ROOT", tmp_path)
    path = tmp_path / "nb.ipynb"

    def git(*args: str) -> str:
        out = notebooks_full.git("-c", "user.name=t", "-c", "user.email=t@t", *args)
        assert out is not None, args
        return out

    def commit(code: str, printed: str, message: str) -> str:
        nb = nbformat.v4.new_notebook()
        nb.cells = [nbformat.v4.new_code_cell(code)]
        nb.cells[0].outputs = [nbformat.v4.new_output("stream", name="stdout", text=printed)]
        nbformat.write(nb, path)
        git("add", "nb.ipynb")
        git("commit", "-q", "-m", message)
        return git("rev-parse", "HEAD")

    git("init", "-q", "-b", "main")
    commit("print(1)", "1\n", "first outputs")
    git("checkout", "-q", "-b", "run")
    executed = commit("print(2)", "2\n", "executed")
    git("checkout", "-q", "main")
    (tmp_path / "other.txt").write_text("x")
    git("add", "other.txt")
    git("commit", "-q", "-m", "elsewhere")
    git("merge", "-q", "--no-ff", "-m", "merge", "run")
    assert notebooks_full.commit_of_outputs(path) == executed
    commit("print(1 + 1)", "2\n", "code edited, outputs kept")
    assert notebooks_full.commit_of_outputs(path) == executed
    record = notebooks_full.stamp_provenance(path)
    assert record["library_commit"] == executed and record["recorded"] == "stamped without executing"
    nb = nbformat.read(path, as_version=4)
    assert not changed_cells(nb.metadata[notebooks_full.PROVENANCE], notebooks_full.content_digests(nb), nb)
    nb.cells[0].outputs[0].text = "3\n"
    nbformat.write(nb, path)
    assert notebooks_full.commit_of_outputs(path) is None
