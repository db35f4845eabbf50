"""Nothing lost, nothing silent: bad values are refused before anything is written, one bad
update cannot wreck a policy, interrupts checkpoint, and a run directory has one writer.

Every refusal is checked for its exit status, a single ``error:`` line, and run directories
that are byte-identical afterwards.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import test_cli

from jaxpg import envs
from jaxpg.algos import npg, ppo
from jaxpg.run.command import command_line, main, planning
from jaxpg.run.outputs import metrics_log
from jaxpg.run.rundir import layout, replacing, run_lock
from jaxpg.run.training import session

ROOT = Path(__file__).resolve().parent.parent
TINY = test_cli.TINY  # the same tiny run as tests/test_cli.py: the two share its compiled programs


def digest(path: Path) -> dict[str, str]:
    """Every file under ``path`` with the hash of its bytes."""
    files = (p for p in path.rglob("*") if p.is_file())
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


@pytest.fixture(scope="module")
def existing(tmp_path_factory) -> Path:
    """A finished run: 4 iterations, checkpoints at 2 and 4."""
    run_dir = tmp_path_factory.mktemp("runs") / "existing"
    assert main.main([*TINY, "--iterations", "4", "--run-dir", str(run_dir)]) == 0
    return run_dir


BAD_VALUES = [
    (["--policy", "bogus"], "argument --policy: invalid choice: 'bogus' (choose from"),
    (["--policy-activation", "nope"], "argument --policy-activation: invalid choice"),
    (["--value-activation", "nope"], "argument --value-activation: invalid choice"),
    (["--network-init", "nope"], "argument --network-init: invalid choice"),
    (["--policy-hidden", "0"], "policy_hidden must be positive"),
    (["--value-hidden", "16", "-3"], "value_hidden must be positive"),
    (["--gamma", "1.5"], "gamma must be in [0, 1]"),
    (["--gamma", "-1"], "gamma must be in [0, 1]"),
    (["--gae-lambda", "5"], "gae_lambda must be in [0, 1]"),
    (["--max-episode-steps", "0"], "--max-episode-steps must be >= 1"),
    (["--kl-delta", "0"], "kl_delta must be > 0"),
    (["--kl-delta", "nan"], "argument --kl-delta: must be a finite number, got nan"),
    (["--cg-damping", "-1"], "cg_damping must be >= 0"),
    (["--value-lr", "0"], "value_lr must be > 0"),
    (["--value-epochs", "0"], "value_epochs"),
    (["--num-envs", "0"], "num_envs must be >= 1"),
    (["--horizon", "-4"], "horizon must be >= 1"),
    (["--eval-every", "0"], "eval_every >= 1"),
    (["--eval-horizon", "-1"], "eval_horizon must be >= 0"),
    (["--max-update-kl", "-1"], "max_update_kl must be >= 0"),
    (["--log-std-init", "inf"], "argument --log-std-init: must be a finite number, got inf"),
    (["--sampling", "sideways"], "argument --sampling: invalid choice"),
    (["--fvp", "exact"], "argument --fvp: invalid choice"),
    (["--algo", "a2c", "--optimizer", "adamw"], "invalid choice: 'adamw' (choose from 'rmsprop', 'adam')"),
    (["--algo", "trpo", "--kl-delta", "0.1"], "unrecognized arguments: --kl-delta"),
    (["--algo", "reinforce", "--value-hidden", "8"], "unrecognized arguments: --value-hidden"),
    (["--algo", "ppo", "--lr", "0"], "lr must be > 0"),
    (["--algo", "a2c", "--gae-lambda", "2"], "gae_lambda must be in [0, 1]"),
    (["--algo", "reinforce", "--gamma", "2"], "gamma must be in [0, 1]"),
]


@pytest.mark.parametrize(("flags", "message"), BAD_VALUES, ids=[" ".join(f) for f, _ in BAD_VALUES])
def test_bad_values_are_one_line_and_the_existing_run_is_untouched(flags, message, existing, capsys):
    before = digest(existing)
    status = main.main([*TINY, "--iterations", "4", "--run-dir", str(existing), "--overwrite", *flags])
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.count("\n") == 1 and err.startswith("error: ") and message in err, err
    assert digest(existing) == before
    assert not list(existing.parent.glob("existing.replaced-*"))


def test_npg_step_that_overshoots_is_shrunk_or_rejected():
    """With a normalised step of 1e6 every candidate overshoots: the update is rolled back (the
    policy is unchanged) and counted; a sane step is taken whole and stays within its bound. Both
    through ``npg.update_with_kl_delta``, whose traced step size lets one compiled program take
    both (it is ``update`` with ``config.kl_delta`` replaced, as test_npg_sweep checks)."""
    env = envs.make("inverted_pendulum")
    config = npg.Config(num_envs=8, horizon=32, eval_envs=0, value_batch_size=64, cg_damping=1e-2)
    ts = npg.init(jax.random.PRNGKey(0), env, config)
    update = jax.jit(npg.update_with_kl_delta)
    after, metrics = update(ts, jnp.float32(1e6))
    assert float(metrics["update_rejected"]) == 1.0 and float(metrics["step_fraction"]) == 0.0
    for a, b in zip(jax.tree.leaves(after.params), jax.tree.leaves(ts.params), strict=True):
        np.testing.assert_array_equal(a, b)
    assert int(after.failures) == 0  # a rolled-back step is not a non-finite failure
    after, metrics = update(ts, jnp.float32(config.kl_delta))
    assert float(metrics["update_rejected"]) == 0.0 and float(metrics["step_fraction"]) == 1.0
    assert 0 < float(metrics["kl"]) <= npg.kl_bound(config)


def test_ppo_update_far_outside_the_trust_region_is_rolled_back():
    env = envs.make("inverted_pendulum")
    config = ppo.Config(**{**ppo.PRESETS["pendulum"], "lr": 100.0, "eval_envs": 0})
    ts = ppo.init(jax.random.PRNGKey(0), env, config)
    after, metrics = jax.jit(ppo.update)(ts)
    assert float(metrics["kl"]) > config.max_update_kl and float(metrics["update_rejected"]) == 1.0
    for a, b in zip(jax.tree.leaves(after.params), jax.tree.leaves(ts.params), strict=True):
        np.testing.assert_array_equal(a, b)


def command(*args: str) -> list[str]:
    return [sys.executable, "-m", "jaxpg.cli", *TINY, *args]


def wait_for(path: Path, timeout: float = 900) -> None:
    """Until ``path`` exists (a guard against hangs, not a speed requirement)."""
    deadline = time.monotonic() + timeout
    while not path.exists():
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.2)


@pytest.mark.parametrize(("signum", "status"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupt_finishes_the_call_writes_a_checkpoint_and_resume_continues(signum, status, tmp_path):
    run_dir = tmp_path / "run"
    proc = subprocess.Popen(
        command("--iterations", "100000", "--run-dir", str(run_dir)), stderr=subprocess.PIPE, text=True
    )
    wait_for(run_dir / layout.METRICS_FILE)
    while not metrics_log.read_metrics(run_dir):
        time.sleep(0.2)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=900)
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("WARNING")]
    assert proc.returncode == status, err[-2000:]
    assert len(lines) == 1 and f"{signal.Signals(signum).name}: stopped after iteration" in lines[0], lines
    stopped = max(r["iteration"] for r in metrics_log.read_metrics(run_dir))
    assert (run_dir / layout.CHECKPOINT_DIR / str(stopped)).is_dir()
    assert not (run_dir / layout.LOCK_FILE).exists()
    resumed = subprocess.run(
        [sys.executable, "-m", "jaxpg.cli", "--resume", str(run_dir), "--iterations", str(stopped + 2)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert f"resuming at iteration {stopped}" in resumed.stdout


def test_interrupt_before_the_first_iteration_leaves_nothing(tmp_path):
    """While the first compiled call is still compiling an interrupt stops at once and removes the
    new run directory, so that the same command can simply be run again."""
    run_dir = tmp_path / "run"
    argv = command("--iterations", "4", "--run-dir", str(run_dir))
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for(run_dir / layout.CONFIG_FILE)  # the directory exists, the first block is compiling
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=900)
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("WARNING")]
    assert proc.returncode == 130, err[-2000:]
    assert len(lines) == 1 and "SIGINT: stopped at once" in lines[0] and "was removed" in lines[0], lines
    assert not run_dir.exists()
    rerun = subprocess.run(argv, capture_output=True, timeout=900)
    assert rerun.returncode == 0


def test_overwritten_run_comes_back_when_the_new_run_writes_no_checkpoint(existing, tmp_path):
    """``--overwrite`` moves the old run aside; a new run that ends without a checkpoint puts it
    back (here: a planned run finished before any training)."""
    copy = tmp_path / "copy"
    subprocess.run(["cp", "-r", str(existing), str(copy)], check=True)
    before = digest(copy)
    plan = planning.plan([*TINY, "--iterations", "4", "--run-dir", str(copy), "--overwrite"], command_line.Experiment())
    lock = run_lock.RunLock(copy)
    replacing.prepare_run_dir(plan, lock)
    assert plan.replaced is not None and plan.replaced.exists() and digest(copy) != before
    assert lock.held and (copy / layout.LOCK_FILE).exists()  # the new directory is locked
    note = replacing.finish_run_dir(plan, checkpointed=False)
    lock.release()
    assert "is back" in note and digest(copy) == before and not plan.replaced.exists()
    assert names(tmp_path) == ["copy"]


def test_a_second_writer_is_refused_and_a_stale_lock_is_taken_over(existing, capsys, tmp_path):
    copy = tmp_path / "copy"
    subprocess.run(["cp", "-r", str(existing), str(copy)], check=True)
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        import platform

        (copy / layout.LOCK_FILE).write_text(json.dumps({"pid": sleeper.pid, "host": platform.node(), "started": "x"}))
        before = digest(copy)
        for argv in (["--resume", str(copy), "--iterations", "6"], [*TINY, "--run-dir", str(copy), "--overwrite"]):
            assert main.main(argv) == 2
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and f"in use by process {sleeper.pid}" in err, err
            assert layout.LOCK_FILE in err, err  # the file to delete if that process is in fact gone
            assert digest(copy) == before
    finally:
        sleeper.kill()
        sleeper.wait()
    assert main.main(["--resume", str(copy), "--iterations", "6"]) == 0  # the lock's process is gone
    assert not (copy / layout.LOCK_FILE).exists()
    assert max(r["iteration"] for r in metrics_log.read_metrics(copy)) == 6


@pytest.mark.parametrize("damage", ["deleted", "shortened"])
def test_resume_refuses_metrics_that_do_not_reach_the_checkpoint(damage, existing, capsys, tmp_path):
    copy = tmp_path / "copy"
    subprocess.run(["cp", "-r", str(existing), str(copy)], check=True)
    metrics = copy / layout.METRICS_FILE
    if damage == "deleted":
        metrics.unlink()
    else:
        metrics.write_text("".join(metrics.read_text().splitlines(keepends=True)[:1]))
    before = digest(copy)
    assert main.main(["--resume", str(copy)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "metrics.jsonl" in err and "checkpoint is at iteration 4" in err, err
    assert digest(copy) == before


def test_unwritable_run_directory_is_one_line(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    status = main.main([*TINY, "--iterations", "2", "--run-dir", str(blocker / "run")])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and err.startswith("error: "), err
    assert blocker.read_text() == "not a directory" and os.path.isfile(blocker)


def test_interrupt_between_writing_the_run_directory_and_the_training_loop(tmp_path, monkeypatch, capsys):
    """An interrupt after the run directory is written but before the training loop's own handler
    is armed (imports, profiling, device placement) is cleaned up the same way: exit status 130,
    one line, and the new run directory removed. (Under load the window lasts seconds.)"""

    def interrupted(plan_, ts, wall_offset, interrupts):
        assert (plan_.run_dir / layout.CONFIG_FILE).exists()
        raise KeyboardInterrupt

    monkeypatch.setattr(session, "_train", interrupted)
    run_dir = tmp_path / "run"
    try:
        status = main.main([*TINY, "--iterations", "4", "--run-dir", str(run_dir)])
    except KeyboardInterrupt:
        pytest.fail("the interrupt escaped main.main (the run directory is left behind)")
    assert status == 130
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1 and "SIGINT: stopped at once" in lines[0] and "was removed" in lines[0], lines
    assert not run_dir.exists()


# --------------------------------------------------------------------------- run directories: nothing lost


def copy_run(existing: Path, path: Path) -> Path:
    shutil.copytree(existing, path, symlinks=True)
    return path


def one_error_line(err: str, *parts: str) -> str:
    """``err`` is exactly one ``error:`` line holding every one of ``parts``; returns it."""
    assert err.count("\n") == 1 and err.startswith("error: "), err
    assert all(part in err for part in parts), err
    return err.strip()


def names(path: Path) -> list[str]:
    return sorted(os.listdir(path))


def dead_pid() -> int:
    """The process id of a process that has ended."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def foreign_app(tmp_path: Path, existing: Path) -> Path:
    """Someone's project that happens to have a config.json."""
    path = tmp_path / "proj"
    (path / "src").mkdir(parents=True)
    (path / "config.json").write_text('{"name": "app"}\n')
    (path / "src" / "important.txt").write_text("x\n")
    return path


def run_with_notes(tmp_path: Path, existing: Path) -> Path:
    """A jaxpg run with a file of the user's beside it."""
    path = copy_run(existing, tmp_path / "run")
    (path / "notes.txt").write_text("keep me\n")
    return path


def link_to_foreign(tmp_path: Path, existing: Path) -> Path:
    """A symbolic link to a directory that is not a jaxpg run."""
    target = tmp_path / "store" / "thesis"
    target.mkdir(parents=True)
    (target / "thesis.tex").write_text("precious\n")
    link = tmp_path / "runs" / "link"
    link.parent.mkdir()
    link.symlink_to(target)
    return link


@pytest.mark.parametrize("make", [foreign_app, run_with_notes, link_to_foreign], ids=lambda f: f.__name__)
def test_overwrite_refuses_what_is_not_only_a_jaxpg_run(make, existing, tmp_path, capsys):
    """``--overwrite`` replaces a directory only if its config.json reads as a jaxpg run and it
    holds nothing a run does not write; anything else is one ``error:`` line and nothing moves."""
    path = make(tmp_path, existing)
    before, around = digest(path.resolve()), {p: names(p) for p in {path.parent, path.resolve().parent}}
    status = main.main([*TINY, "--iterations", "2", "--run-dir", str(path), "--overwrite"])
    one_error_line(capsys.readouterr().err, "refusing to --overwrite")
    assert status == 2
    assert digest(path.resolve()) == before and {p: names(p) for p in around} == around


def test_overwrite_through_a_symbolic_link_keeps_the_link(existing, tmp_path, capsys):
    """A run directory given as a symbolic link to a jaxpg run: the run in the link's target is
    replaced; the link stays a link to it, and nothing is left beside either."""
    target = copy_run(existing, tmp_path / "store" / "real")
    link = tmp_path / "runs" / "link"
    link.parent.mkdir()
    link.symlink_to(target)
    assert main.main([*TINY, "--iterations", "2", "--run-dir", str(link), "--overwrite"]) == 0, capsys.readouterr()
    assert link.is_symlink() and link.resolve() == target.resolve()
    assert [r["iteration"] for r in metrics_log.read_metrics(target)] == [1, 2]
    assert json.loads((target / layout.CONFIG_FILE).read_text())["iterations"] == 2
    assert names(link.parent) == ["link"] and names(target.parent) == ["real"]


def test_zero_iterations_is_refused_and_writes_nothing(existing, tmp_path, capsys):
    """A new run of 0 iterations would leave a run directory without a checkpoint (nothing to
    resume), or, with ``--overwrite``, hide the old run: refused before anything is written."""
    copy = copy_run(existing, tmp_path / "copy")
    before = digest(copy)
    for argv in (["--run-dir", str(tmp_path / "new")], ["--run-dir", str(copy), "--overwrite"]):
        assert main.main([*TINY, "--iterations", "0", *argv]) == 2
        one_error_line(capsys.readouterr().err, "--iterations")
    assert names(tmp_path) == ["copy"] and digest(copy) == before


def test_a_writer_that_finds_the_directory_taken_writes_nothing(tmp_path, capsys):
    """Two new runs into one directory, planned while it was free: the one that comes second to
    the directory finds it locked by the first, exits with status 2 naming that process, and
    changes no byte of the first one's files (the lock comes before any write)."""
    run_dir = tmp_path / "race"
    second = planning.plan(
        [*TINY, "--iterations", "2", "--seed", "7", "--run-dir", str(run_dir)], command_line.Experiment()
    )
    first = subprocess.Popen(command("--iterations", "100000", "--run-dir", str(run_dir)), stderr=subprocess.DEVNULL)
    try:
        wait_for(run_dir / layout.CONFIG_FILE)  # written once the first holds the lock
        first.send_signal(signal.SIGSTOP)  # its files hold still while the second tries
        assert json.loads((run_dir / layout.LOCK_FILE).read_text())["pid"] == first.pid
        before = digest(run_dir)
        status = session.execute(second)
        one_error_line(capsys.readouterr().err, f"in use by process {first.pid}")
        assert status == 2
        assert digest(run_dir) == before and names(tmp_path) == ["race"]
        assert json.loads((run_dir / layout.CONFIG_FILE).read_text())["seeds"] == [0]
    finally:
        first.kill()
        first.wait()


def test_overwrite_killed_before_its_first_checkpoint_is_undone_by_the_next_command(existing, tmp_path, capsys):
    """``kill -9`` of an ``--overwrite`` run while it compiles leaves the old run moved aside; the
    next command on that directory finds it (its process has ended, the new run has no
    checkpoint), puts it back, and says so."""
    copy = copy_run(existing, tmp_path / "copy")
    before = digest(copy)
    argv = command("--iterations", "100000", "--checkpoint-every", "0", "--run-dir", str(copy), "--overwrite")
    proc = subprocess.Popen(argv, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 900
    while not (list(tmp_path.glob("copy.replaced-*")) and (copy / layout.CONFIG_FILE).exists()):
        assert time.monotonic() < deadline and proc.poll() is None, "the old run was never moved aside"
        time.sleep(0.1)
    proc.kill()
    proc.wait()
    assert main.main(["--resume", str(copy), "--iterations", "4"]) == 0
    captured = capsys.readouterr()
    notes = [line for line in captured.err.splitlines() if line.strip()]
    assert len(notes) == 1 and notes[0].startswith("note: ") and f"copy.replaced-{proc.pid}" in notes[0], notes
    assert "nothing to do" in captured.out
    assert digest(copy) == before and names(tmp_path) == ["copy"]


def test_a_run_moved_aside_beside_a_resumable_run_is_pointed_to(existing, tmp_path, capsys):
    """An old run moved aside by an ``--overwrite`` whose process ended after the new run's first
    checkpoint: both are kept, and each command on the directory says where the old one is."""
    run_dir = copy_run(existing, tmp_path / "run")
    aside = copy_run(existing, tmp_path / f"run.replaced-{dead_pid()}")
    before = digest(tmp_path)
    assert main.main(["--resume", str(run_dir), "--iterations", "4"]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(notes) == 1 and notes[0].startswith("note: ") and str(aside) in notes[0], notes
    assert digest(tmp_path) == before


def test_resume_with_nothing_to_do_writes_nothing(existing, capsys):
    before = digest(existing)
    assert main.main(["--resume", str(existing), "--iterations", "2"]) == 0
    assert "nothing to do" in capsys.readouterr().out
    assert digest(existing) == before


def test_resume_refuses_a_damaged_line_inside_the_metrics(existing, tmp_path, capsys):
    """A line that is not JSON in the middle of metrics.jsonl (not a torn last line, which a
    killed process leaves and a resume drops) is named, and the file is left as it is."""
    copy = copy_run(existing, tmp_path / "copy")
    lines = (copy / layout.METRICS_FILE).read_text().splitlines(keepends=True)
    lines[1] = lines[1][: len(lines[1]) // 2] + "\n"
    (copy / layout.METRICS_FILE).write_text("".join(lines))
    before = digest(copy)
    assert main.main(["--resume", str(copy), "--iterations", "6"]) == 2
    one_error_line(capsys.readouterr().err, "metrics.jsonl", "line 2")
    assert digest(copy) == before


def test_resume_of_a_file_says_it_is_not_a_run_directory(tmp_path, capsys):
    path = tmp_path / "README.md"
    path.write_text("# hello\n")
    assert main.main(["--resume", str(path)]) == 2
    line = one_error_line(capsys.readouterr().err, "not a run directory")
    assert "does not exist" not in line


def test_a_run_without_a_checkpoint_points_to_overwrite(existing, tmp_path, capsys):
    """A run directory left without a checkpoint (its process was killed before the first one):
    a new run into it and ``--resume`` both say that ``--overwrite`` starts it again, which works."""
    copy = copy_run(existing, tmp_path / "copy")
    shutil.rmtree(copy / layout.CHECKPOINT_DIR)
    before = digest(copy)
    assert main.main([*TINY, "--iterations", "2", "--run-dir", str(copy)]) == 2
    assert "--resume" not in one_error_line(capsys.readouterr().err, "no checkpoint", "--overwrite")
    assert main.main(["--resume", str(copy)]) == 2
    one_error_line(capsys.readouterr().err, "no checkpoint", "--overwrite")
    assert digest(copy) == before
    assert main.main([*TINY, "--iterations", "2", "--run-dir", str(copy), "--overwrite"]) == 0
    assert [r["iteration"] for r in metrics_log.read_metrics(copy)] == [1, 2]


def disk_full_on_save(monkeypatch) -> None:
    """Every checkpoint save fails as a full disk does."""
    import errno

    import orbax.checkpoint as ocp

    def full(manager, step, *args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(manager.directory))

    monkeypatch.setattr(ocp.CheckpointManager, "save", full)


def test_disk_full_before_the_first_checkpoint_says_what_is_on_disk(existing, tmp_path, monkeypatch, capsys):
    """The disk fills before a new run's first checkpoint: the run it replaced is back (or the new
    directory is gone), and the one error line says so instead of advising ``--resume``."""
    copy = copy_run(existing, tmp_path / "copy")
    before = digest(copy)
    disk_full_on_save(monkeypatch)
    assert main.main([*TINY, "--iterations", "2", "--run-dir", str(copy), "--overwrite"]) == 2
    line = one_error_line(capsys.readouterr().err, "disk is full", f"back in {copy}")
    assert "--resume" not in line
    assert digest(copy) == before and names(tmp_path) == ["copy"]
    assert main.main([*TINY, "--iterations", "2", "--run-dir", str(tmp_path / "new")]) == 2
    assert "--resume" not in one_error_line(capsys.readouterr().err, "disk is full", "was removed")
    assert names(tmp_path) == ["copy"]


def test_printed_commands_are_shell_quoted(existing, tmp_path, capsys):
    """Commands printed for the user work when pasted into a shell, whatever the run directory's name."""
    import shlex

    run_dir = tmp_path / "my runs" / "it's"
    assert main.main([*TINY, "--iterations", "8", "--minutes", "1e-9", "--run-dir", str(run_dir)]) == 0
    out = capsys.readouterr().out
    resume = re.search(r"continue with: (python -m jaxpg\.cli --resume .*)\)$", out, flags=re.M)
    assert resume and shlex.split(resume.group(1))[-1] == str(run_dir), out
    assert main.main([*TINY, "--iterations", "4", "--run-dir", str(run_dir)]) == 2
    assert f"--resume {shlex.quote(str(run_dir))}" in capsys.readouterr().err


def test_disk_full_while_writing_metrics_is_one_line_and_keeps_the_checkpoints(existing, tmp_path, monkeypatch, capsys):
    """A full disk while writing a block's metrics ends the run with one ``error:`` line and status 2,
    before the checkpoint that would cover those iterations: the checkpoint before it, whose
    metrics are all on disk, resumes."""
    import errno

    copy = copy_run(existing, tmp_path / "copy")
    real_write = metrics_log.JsonlLog.write

    def full_after_iteration_2(writer, records):
        if records and records[0]["iteration"] > 4:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(writer.run_dir / layout.METRICS_FILE))
        real_write(writer, records)

    monkeypatch.setattr(metrics_log.JsonlLog, "write", full_after_iteration_2)
    assert main.main(["--resume", str(copy), "--iterations", "8"]) == 2
    one_error_line(capsys.readouterr().err, "writing the run directory failed", "disk full")
    assert [r["iteration"] for r in metrics_log.read_metrics(copy)] == [1, 2, 3, 4]
    monkeypatch.setattr(metrics_log.JsonlLog, "write", real_write)
    assert main.main(["--resume", str(copy), "--iterations", "6"]) == 0
    assert [r["iteration"] for r in metrics_log.read_metrics(copy)] == [1, 2, 3, 4, 5, 6]
