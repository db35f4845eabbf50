"""Nothing lost, nothing silent, for checkpoints: flipped bytes are caught by the checksum manifest
(load_policy, --resume and "best" skip the damaged step with one warning line), checkpoints of an
older jaxpg without a manifest still load, the final checkpoint survives any --keep-checkpoints,
and "best" ranks checkpoints by one kind of return.

One cartpole NPG run directory is written once per module from the algorithm's ``init``
(checkpoints 2 and 4, nothing trained: conftest's ``pristine_run``); tests damage copies of it
(``run_copy``). Nothing is compiled beyond what ``init`` and ``jax.eval_shape`` trace."""

from __future__ import annotations

import json
import re
import types
from pathlib import Path

import jax
import numpy as np
import pytest
from test_checkpoint import make_state

import jaxpg
from jaxpg.run.checkpoints import checkpoint_format
from jaxpg.run.checkpoints.checkpoint_errors import CheckpointError
from jaxpg.run.checkpoints.checkpointer import Checkpointer
from jaxpg.run.command import command_line, main, planning
from jaxpg.run.outputs import metrics_log
from jaxpg.run.rundir import config_io
from jaxpg.run.training import session


def listing(path: Path) -> dict:
    return {str(p.relative_to(path)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(path.rglob("*"))}


def assert_tree_equal(got, want) -> None:
    for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(want), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def flip_bytes(step_dir: Path, item: str, count: int = 64) -> Path:
    """Invert ``count`` bytes in the middle of the largest array data file of ``item`` (OCDBT's
    ``d/`` files): the file keeps its size, so only its contents tell the damage (what a failing
    disk or a stray write does)."""
    files = [p for p in (step_dir / item).rglob("*") if p.is_file() and p.parent.name == "d"]
    target = max(files, key=lambda p: p.stat().st_size)
    data = bytearray(target.read_bytes())
    assert len(data) >= count
    start = (len(data) - count) // 2
    data[start : start + count] = bytes(b ^ 0xFF for b in data[start : start + count])
    target.write_bytes(bytes(data))
    return target


def damage_reason(step: int, item: str) -> str:
    """The reason a damaged file of ``item`` in ``step`` is reported with: jaxpg's sha256 manifest,
    or, where the installed TensorStore checksums its own chunks (newer versions do, e.g. the GPU
    image's), TensorStore's data-loss error, which is read before the manifest is checked."""
    return rf"(?:{step}/{item}/\S+ does not match its sha256 checksum .*|its {item} item is unreadable: data loss: .*)"


def checksum_warning(err: str, item: str, bad: int = 4, used: int = 2) -> None:
    """``err`` is exactly one line: the warning that ``bad`` was skipped because a file of ``item``
    is damaged (``damage_reason``)."""
    lines = err.splitlines()
    assert len(lines) == 1, err
    pattern = rf"warning: checkpoint {bad} is damaged \({damage_reason(bad, item)}\); "
    assert re.fullmatch(pattern + rf"using checkpoint {used}", lines[0]), lines[0]


def test_flipped_bytes_in_the_policy_item_are_caught_by_load_policy(pristine_run, run_copy, capfd):
    flip_bytes(run_copy / "checkpoints" / "4", "policy")
    before = listing(run_copy)
    policy = jaxpg.load_policy(run_copy)
    checksum_warning(capfd.readouterr().err, "policy")
    assert policy.step == 2  # which step it used
    assert_tree_equal(policy.params, pristine_run.state(2).params)
    # Asked for by number, the damaged step is one error line, not another step.
    with pytest.raises(CheckpointError, match=rf"^checkpoint step 4 in \S+ is damaged \({damage_reason(4, 'policy')}"):
        jaxpg.load_policy(run_copy, 4)
    assert listing(run_copy) == before


def test_flipped_bytes_in_the_state_item_make_resume_fall_back(pristine_run, run_copy, capfd):
    flip_bytes(run_copy / "checkpoints" / "4", "state")
    before = listing(run_copy)
    plan = planning.plan(["--resume", str(run_copy), "--iterations", "6"], command_line.Experiment())
    checksum_warning(capfd.readouterr().err, "state")
    assert plan.start == 2
    assert_tree_equal(plan.state, pristine_run.state(2))
    assert listing(run_copy) == before


def test_no_intact_checkpoint_is_one_error_line(run_copy, capfd):
    flip_bytes(run_copy / "checkpoints" / "4", "state")
    flip_bytes(run_copy / "checkpoints" / "2", "policy")
    before = listing(run_copy)
    with pytest.raises(CheckpointError, match=r"^no checkpoint in \S+ reads back completely \(checkpoint 4 and 1 "):
        jaxpg.load_policy(run_copy)
    assert main.main(["--resume", str(run_copy)]) == 2
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("error: no checkpoint in "), err
    assert listing(run_copy) == before


def test_a_missing_manifest_of_a_new_checkpoint_is_damage(pristine_run, run_copy, capfd):
    """A save killed after Orbax's commit but before the manifest: meta promises one."""
    (run_copy / "checkpoints" / "4" / checkpoint_format.MANIFEST).unlink()
    policy = jaxpg.load_policy(run_copy)
    err = capfd.readouterr().err.splitlines()
    assert err == [
        "warning: checkpoint 4 is damaged (its checksum manifest is missing (the save did not finish)); "
        "using checkpoint 2"
    ]
    assert policy.step == 2


def make_old(step_dir: Path) -> None:
    """``step_dir`` as an older jaxpg wrote it: no manifest, and no promise of one in ``meta``."""
    (step_dir / checkpoint_format.MANIFEST).unlink()
    meta_path = step_dir / "meta" / "metadata"
    meta = json.loads(meta_path.read_text())
    del meta[checkpoint_format.CHECKSUMS_KEY]
    meta_path.write_text(json.dumps(meta))


def test_old_checkpoints_without_a_manifest_load_with_one_note(pristine_run, run_copy, capfd):
    for step in (2, 4):
        make_old(run_copy / "checkpoints" / str(step))
    policy = jaxpg.load_policy(run_copy, "latest")
    assert policy.step == 4
    assert_tree_equal(policy.params, pristine_run.state(4).params)
    reader = Checkpointer(run_copy / "checkpoints")
    assert reader.damage(4) is None and reader.damage(2) is None  # two old steps: still one note
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 2 and all(
        re.fullmatch(r"note: checkpoint \d in \S+ has no checksum manifest .*", e) for e in err
    )


# --------------------------------------------------------------------------- retention and "best"


def test_final_checkpoint_survives_keep_zero(tmp_path):
    """keep 0 with an older best: the newest step is kept as well (it is what --resume continues)."""
    ckpt = Checkpointer(tmp_path, keep=0, create=True)
    for step, score in ((2, 9.0), (4, 1.0), (6, 2.0)):
        ckpt.save(step, make_state(step), score=score)
    assert ckpt.steps() == [2, 6]
    assert ckpt.latest_step() == 6 and ckpt.best_step() == 2


def test_keep_checkpoints_zero_is_refused_on_the_command_line(run_copy, capsys):
    before = listing(run_copy)
    fresh = ["--keep-checkpoints", "0", "--run-dir", str(run_copy / "new")]
    for argv in (fresh, ["--resume", str(run_copy), "--keep-checkpoints", "0"]):
        assert main.main(argv) == 2
        err = capsys.readouterr().err.splitlines()
        assert err == ["error: argument --keep-checkpoints: must be >= 1 (the latest checkpoint is always kept), got 0"]
    assert listing(run_copy) == before


def test_checkpoint_score_compares_like_with_like():
    nan = np.nan
    block = {"return_stochastic": np.array([5.0, 50.0]), "return_mean_policy": np.array([nan, nan])}
    # The run evaluates its mean policy: a block without an evaluation has no score (never its
    # stochastic return, which is on another scale), one with an evaluation its mean-policy return.
    assert metrics_log.checkpoint_score(block, evaluated=True) == -np.inf
    assert metrics_log.checkpoint_score({**block, "return_mean_policy": np.array([nan, 7.0])}, evaluated=True) == 7.0
    # A run without evaluations ranks every checkpoint by the stochastic return of its last iteration.
    assert metrics_log.checkpoint_score(block, evaluated=False) == 50.0
    several = {"return_stochastic": np.array([[1.0, 3.0]]), "return_mean_policy": np.array([[2.0, 6.0]])}
    assert metrics_log.checkpoint_score(several, evaluated=True) == 4.0  # mean over seeds


def test_end_of_run_report_never_recommends_a_damaged_best(pristine_run, run_copy, capsys):
    """Checkpoint 4 scores highest but is damaged: the report names the best intact one, 2."""
    flip_bytes(run_copy / "checkpoints" / "4", "state")
    ckpt = Checkpointer(run_copy / "checkpoints", keep=None)
    ckpt.save(6, pristine_run.state(6), score=1.0, info={"task": "cartpole", "algo": "npg", "seeds": [0]})
    ckpt.close()
    run = config_io.RunConfig.load(run_copy)
    plan = types.SimpleNamespace(run=run, run_dir=run_copy, profile=False)
    callbacks = types.SimpleNamespace(
        block_times=[(2, 1.0)], host_times=[(2, 1.5)], eval_seconds=0.0, evaluations=0, samples=32
    )
    session._report_end(plan, callbacks)
    captured = capsys.readouterr()
    assert "best checkpoint: iteration 2 (return 2.0); evaluate it with --step best" in captured.out, captured.out
    assert "host work between blocks: 1.5 s beside those 1.0 s" in captured.out, captured.out
    assert "iteration 4" not in captured.out
    assert re.search(rf"warning: checkpoint 4 is damaged \({damage_reason(4, 'state')}", captured.err), captured.err
