"""Run directories under hostile use: a second Ctrl-C, ``--overwrite`` of the working directory or
of a run holding foreign entries deeper down, a run inside a run, racing writers on a stale lock.
Most tests call the host-side functions directly (no training, nothing compiled); one starts the
command line to interrupt it twice."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
import test_cli

from jaxpg.run.command import main
from jaxpg.run.command.plan import Plan
from jaxpg.run.rundir import directory, layout, replacing
from jaxpg.run.rundir.layout import RunDirError

TINY = test_cli.TINY  # the command line's tiny pendulum run, whose programs the suite compiles anyway


def digest(path: Path) -> dict[str, str]:
    """Every file under ``path`` with the hash of its bytes."""
    files = (p for p in path.rglob("*") if p.is_file())
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


def one_error_line(err: str, *parts: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert all(part in lines[0] for part in parts), err
    return lines[0]


def fresh_plan(run_dir: Path, replaced: Path | None = None) -> Plan:
    """The plan of a new run that made ``run_dir`` (or, with ``replaced``, moved an old run there)."""
    return Plan(
        run=None, run_dir=run_dir, module=None, env=None, config=None, fresh=True, created=True, replaced=replaced
    )


# --------------------------------------------------------------------------- a second Ctrl-C


def test_a_run_with_a_checkpoint_is_never_removed_by_an_interrupt(run_copy):
    """The session's belief (``checkpointed=False``: a second Ctrl-C came before the checkpoint was
    noted) does not decide: the directory holds checkpoints, so it stays, and the note says how
    to continue."""
    before = digest(run_copy)
    assert replacing.finish_run_dir(fresh_plan(run_copy), checkpointed=False) == ""
    assert digest(run_copy) == before
    note = replacing.stopped_at_once_note(fresh_plan(run_copy), checkpointed=False)
    assert "continue from its latest checkpoint with: python -m jaxpg.cli --resume" in note
    assert digest(run_copy) == before


def test_an_interrupted_overwrite_keeps_the_new_run_once_it_has_a_checkpoint(run_copy, tmp_path):
    """``--overwrite``: once the new run has a checkpoint, an interrupt keeps it (the old run that
    was moved aside is dropped, as at a normal end) instead of throwing it away."""
    old = tmp_path / "run.replaced-1"
    old.mkdir()
    (old / layout.CONFIG_FILE).write_text("{}\n")
    before = digest(run_copy)
    assert replacing.finish_run_dir(fresh_plan(run_copy, replaced=old), checkpointed=False) == ""
    assert digest(run_copy) == before and not old.exists()


def test_a_run_without_a_checkpoint_is_still_removed(tmp_path):
    run_dir = tmp_path / "new"
    run_dir.mkdir()
    (run_dir / layout.CONFIG_FILE).write_text("{}\n")
    note = replacing.stopped_at_once_note(fresh_plan(run_dir), checkpointed=False)
    assert "was removed (no checkpoint had been written)" in note and not run_dir.exists()


def test_a_second_ctrl_c_keeps_the_checkpointed_run(tmp_path):
    """A second SIGINT right after the first one's "checkpoint N written" line (the run is closing,
    waiting for the curves' last drawing): exit 130, and the run and its checkpoints stay for
    ``--resume`` (before, the second one deleted the run it had just saved)."""
    run_dir = tmp_path / "run"
    argv = [sys.executable, "-m", "jaxpg.cli", *TINY, "--iterations", "100000", "--run-dir", str(run_dir)]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 900  # a guard against hangs, not a speed requirement
    while not any((run_dir / layout.CHECKPOINT_DIR).glob("[0-9]*/" + "jaxpg_sha256.json")):
        assert time.monotonic() < deadline and proc.poll() is None, "no checkpoint appeared"
        time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if "stopped after iteration" in line:
            proc.send_signal(signal.SIGINT)
            break
    _, err = proc.communicate(timeout=900)
    err = "".join(seen) + err
    assert proc.returncode == 130, err[-2000:]
    assert "was removed" not in err, err
    assert (run_dir / layout.CONFIG_FILE).is_file() and replacing.has_checkpoint(run_dir), err
    assert not (run_dir / layout.LOCK_FILE).exists()


# --------------------------------------------------------------------------- what --overwrite may delete


def test_overwrite_of_the_working_directory_or_above_is_refused(run_copy, monkeypatch, capsys):
    """``--overwrite --run-dir .`` from inside a run (and ``..`` from below it) is one error line;
    nothing changes (before, the old run and the new one were lost to a ``FileNotFoundError``)."""
    before = digest(run_copy)
    monkeypatch.chdir(run_copy)
    assert main.main([*TINY, "--iterations", "2", "--run-dir", ".", "--overwrite"]) == 2
    one_error_line(capsys.readouterr().err, "refusing to --overwrite '.'", "it is the working directory")
    monkeypatch.chdir(run_copy / layout.CHECKPOINT_DIR / "2")
    with pytest.raises(RunDirError, match="a directory above the working directory"):
        directory.check_replaceable(Path("../.."))
    assert digest(run_copy) == before


def add_tensorboard(run_dir: Path) -> None:
    """What a run's TensorBoard writer leaves: ``tensorboard/seed_0/events.out.tfevents.*``."""
    events = run_dir / layout.TENSORBOARD_DIR / "seed_0"
    events.mkdir(parents=True)
    (events / "events.out.tfevents.1700000000.host.123").write_bytes(b"\0" * 16)
    (run_dir / layout.VIDEO_DIR).mkdir()
    (run_dir / layout.VIDEO_DIR / "iter_000002.mp4").write_bytes(b"\0")


FOREIGN = {
    "tensorboard/NOTES.txt": lambda run: (run / "tensorboard" / "NOTES.txt").write_text("mine\n"),
    "tensorboard/seed_0/notes.txt": lambda run: (run / "tensorboard" / "seed_0" / "notes.txt").write_text("mine\n"),
    "videos/talk.pptx": lambda run: (run / "videos" / "talk.pptx").write_text("mine\n"),
    "checkpoints/sub": lambda run: shutil.copytree(run, run / "checkpoints" / "sub", ignore=lambda d, n: ["sub"]),
    "checkpoints/2/extra.bin": lambda run: (run / "checkpoints" / "2" / "extra.bin").write_bytes(b"x"),
    "checkpoints/4/state/mine": lambda run: (run / "checkpoints" / "4" / "state" / "mine").write_bytes(b"x"),
    "checkpoints/best": lambda run: (run / "checkpoints" / "best").symlink_to(run / "checkpoints" / "4"),
}


def test_a_run_as_jaxpg_writes_it_is_replaceable(run_copy):
    add_tensorboard(run_copy)
    directory.check_replaceable(run_copy)
    assert directory.foreign_entries(run_copy) == []


@pytest.mark.parametrize("entry", list(FOREIGN))
def test_overwrite_refuses_foreign_entries_at_any_depth(entry, run_copy):
    """A file or directory jaxpg did not write, anywhere in the run's tree (not only at its top),
    makes the directory not replaceable, and the message names it."""
    add_tensorboard(run_copy)
    FOREIGN[entry](run_copy)
    before = digest(run_copy)
    with pytest.raises(RunDirError, match="besides a jaxpg run it holds") as caught:
        directory.check_replaceable(run_copy)
    assert entry in str(caught.value) and "\n" not in str(caught.value)
    assert directory.foreign_entries(run_copy) == [entry]
    assert digest(run_copy) == before


def test_a_new_run_inside_a_run_is_refused(run_copy, capsys):
    """``--run-dir RUN/checkpoints/sub`` would write a run into another run's checkpoints (which an
    ``--overwrite`` of RUN would then delete): one error line, nothing written."""
    before = digest(run_copy)
    target = run_copy / layout.CHECKPOINT_DIR / "sub"
    assert main.main([*TINY, "--iterations", "2", "--run-dir", str(target)]) == 2
    one_error_line(capsys.readouterr().err, "is inside the jaxpg run")
    assert not target.exists() and digest(run_copy) == before


def test_an_empty_run_dir_is_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main.main([*TINY, "--iterations", "2", "--run-dir", ""]) == 2
    one_error_line(capsys.readouterr().err, "--run-dir is empty")
    assert os.listdir(tmp_path) == []


# --------------------------------------------------------------------------- racing writers


RACE = textwrap.dedent(
    """
    import json, os, sys, tempfile
    from jaxpg.run.rundir import run_lock
    trials, both = int(sys.argv[1]), 0
    for trial in range(trials):
        run_dir = tempfile.mkdtemp()
        with open(os.path.join(run_dir, ".jaxpg.lock"), "w") as f:
            json.dump({"pid": int(sys.argv[2]), "host": run_lock.platform.node(), "started": "x"}, f)
        gate_r, gate_w = os.pipe()
        report_r, report_w = os.pipe()
        done_r, done_w = os.pipe()  # a child that took the lock stays alive until both have tried
        children = []
        for _ in range(2):
            pid = os.fork()
            if pid == 0:
                os.close(gate_w)
                os.read(gate_r, 1)  # both start together
                try:
                    run_lock.RunLock(run_dir).acquire()
                    got = b"1"
                except run_lock.RunDirError:
                    got = b"0"
                os.write(report_w, got)
                os.close(done_w)
                os.read(done_r, 1)
                os._exit(0)
            children.append(pid)
        os.close(gate_r)
        os.close(gate_w)  # releases both
        os.close(done_r)
        got = b""
        while len(got) < 2:
            got += os.read(report_r, 8)
        os.close(done_w)
        for pid in children:
            os.waitpid(pid, 0)
        os.close(report_w)
        os.close(report_r)
        both += got.count(b"1") > 1
    print(both)
    """
)


def test_two_writers_racing_for_a_stale_lock_never_both_take_it(tmp_path):
    """Two processes that find the same stale lock (its process has ended) and take it at the same
    moment: at most one of them gets it, in every trial (before, both did in about a third)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    script = tmp_path / "race.py"
    script.write_text(RACE)
    done = subprocess.run(
        [sys.executable, str(script), "200", str(proc.pid)], capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert int(done.stdout.strip()) == 0


def test_the_lock_record_names_this_process(tmp_path):
    from jaxpg.run.rundir import run_lock

    lock = run_lock.RunLock(tmp_path)
    assert lock.acquire() is None
    assert json.loads((tmp_path / layout.LOCK_FILE).read_text())["pid"] == os.getpid()
    lock.release()
    assert not (tmp_path / layout.LOCK_FILE).exists()


# --------------------------------------------------------------------------- entries of the wrong type


def checkpoints_a_file(run: Path) -> None:
    shutil.rmtree(run / layout.CHECKPOINT_DIR)
    (run / layout.CHECKPOINT_DIR).write_text("mine\n")


WRONG_TYPES = {
    "checkpoints a file": (checkpoints_a_file, "checkpoints' is not a directory, where a run writes a directory"),
    ".jaxpg.lock a directory": (lambda run: (run / layout.LOCK_FILE).mkdir(), ".jaxpg.lock' is a directory"),
    "metrics.jsonl a directory": (
        lambda run: ((run / layout.METRICS_FILE).unlink(), (run / layout.METRICS_FILE).mkdir()),
        "metrics.jsonl' is a directory, where a run writes a file",
    ),
}


@pytest.mark.parametrize("case", list(WRONG_TYPES))
def test_a_run_entry_of_the_wrong_type_is_named(case, run_copy, capsys):
    """``--resume`` names the entry and its type in one ``error:`` line (before: "no checkpoints,
    start again with --overwrite", "metrics end at iteration 0", or an ``OSError`` from the lock);
    ``--overwrite`` counts it as foreign; nothing changes."""
    damage, message = WRONG_TYPES[case]
    damage(run_copy)
    before = digest(run_copy)
    assert main.main(["--resume", str(run_copy), "--iterations", "6"]) == 2
    one_error_line(capsys.readouterr().err, message)
    with pytest.raises(RunDirError, match="besides a jaxpg run it holds"):
        directory.check_replaceable(run_copy)
    assert digest(run_copy) == before


def test_metrics_torn_at_the_checkpoint_point_to_the_earlier_checkpoint(run_copy, capsys):
    """A torn last line at the latest checkpoint's iteration (4): refused, naming the earlier intact
    checkpoint (2) and ``--from-step 2``, which resumes from it."""
    text = (run_copy / layout.METRICS_FILE).read_text()
    (run_copy / layout.METRICS_FILE).write_text(text[: text.rindex("{") + 5])
    before = digest(run_copy)
    assert main.main(["--resume", str(run_copy), "--iterations", "6"]) == 2
    one_error_line(capsys.readouterr().err, "ends at iteration 3", "earlier checkpoint 2 with --from-step 2")
    assert digest(run_copy) == before
