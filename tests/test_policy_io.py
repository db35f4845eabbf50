"""jaxpg.load_policy, python -m jaxpg.evaluate and --resume with damaged checkpoints, observations
with NaN/inf and a path that is a file. One cartpole NPG run directory is written once per module
from the algorithm's ``init`` (checkpoints 2 and 4, nothing trained: conftest's ``pristine_run``);
tests damage copies of it (``run_copy``)."""

import re
import shutil
from pathlib import Path

import jax
import numpy as np
import pytest

import jaxpg
from jaxpg.run.checkpoints import policy_io
from jaxpg.run.checkpoints.checkpoint_errors import CheckpointError
from jaxpg.run.command import command_line, main, planning
from jaxpg.run.evaluation import evaluate_cli
from jaxpg.run.rundir import layout


def listing(path: Path) -> dict:
    return {str(p.relative_to(path)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(path.rglob("*"))}


def truncate_state(run_dir: Path, step: int) -> None:
    files = [p for p in (run_dir / "checkpoints" / str(step) / "state").rglob("*") if p.parent.name == "d"]
    assert files
    for path in files:
        path.write_bytes(path.read_bytes()[:20])


WARNING = re.compile(
    r"warning: checkpoint 4 is damaged \(its state item is unreadable: out of range: 4/state/d/\w+\); "
    r"using checkpoint 2"
)


def test_load_policy_falls_back_to_the_newest_readable_checkpoint(pristine_run, run_copy, capfd):
    truncate_state(run_copy, 4)
    before = listing(run_copy)
    policy = jaxpg.load_policy(run_copy)
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1 and WARNING.fullmatch(err[0]), err
    assert policy.step == 2
    expected = pristine_run.state(2).params
    for got, want in zip(jax.tree.leaves(policy.params), jax.tree.leaves(expected), strict=True):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    assert listing(run_copy) == before


def test_resume_falls_back_to_the_newest_readable_checkpoint(pristine_run, run_copy, capfd):
    (run_copy / "checkpoints" / "4" / "meta" / "metadata").write_text("{")
    before = listing(run_copy)
    plan = planning.plan(["--resume", str(run_copy), "--iterations", "6"], command_line.Experiment())
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1 and re.fullmatch(
        r"warning: checkpoint 4 is damaged \(its meta item is unreadable: JSONDecodeError: .*\); using checkpoint 2",
        err[0],
    ), err
    assert plan.start == 2
    for got, want in zip(jax.tree.leaves(plan.state), jax.tree.leaves(pristine_run.state(2)), strict=True):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    assert listing(run_copy) == before


def test_no_readable_checkpoint_is_one_error_line(run_copy, capfd):
    truncate_state(run_copy, 4)
    shutil.rmtree(run_copy / "checkpoints" / "2" / "policy")
    before = listing(run_copy)
    message = r"no checkpoint in \S+ reads back completely \(.*\); train the run again \(a new --run-dir, or "
    with pytest.raises(CheckpointError, match=message):
        jaxpg.load_policy(run_copy)
    assert capfd.readouterr().err == ""
    assert main.main(["--resume", str(run_copy)]) == 2
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1 and re.match("error: " + message, err[0]), err
    assert listing(run_copy) == before


def test_policy_rejects_observations_with_nan_or_inf(run_copy):
    policy = jaxpg.load_policy(run_copy)
    obs = np.zeros((3, policy.observation_size), np.float32)
    assert policy(obs).shape[0] == 3
    obs[1, 2] = np.nan
    with pytest.raises(ValueError, match=r"^observation contains NaN or inf \(obs\[1, 2\] = nan\); "):
        policy(obs)
    with pytest.raises(ValueError, match=r"^observation contains NaN or inf \(obs\[0\] = -inf\); "):
        policy(np.full(policy.observation_size, -np.inf))


def test_a_file_is_not_a_run_directory(run_copy, capsys):
    path = run_copy / "config.json"
    with pytest.raises(layout.RunDirError, match=r"^'\S+config.json' is a file, not a run directory"):
        jaxpg.load_policy(path)
    with pytest.raises(layout.RunDirError, match="is a file, not a run directory"):
        policy_io.restore_train_state(path)
    assert evaluate_cli.main([str(path), "--episodes", "1"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "is a file, not a run directory" in err[0]
