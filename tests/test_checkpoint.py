"""jaxpg.run.checkpoints.checkpointer: exact round trips, retention (latest k + best), and one clear error for
missing, corrupt, interrupted or incompatible checkpoints. Synthetic pytrees: nothing compiles."""

import errno
import os
import re
import shutil
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from flax import struct

from jaxpg.run.checkpoints.checkpoint_errors import CheckpointError
from jaxpg.run.checkpoints.checkpoint_format import find_tmp_dirs, policy_part
from jaxpg.run.checkpoints.checkpointer import Checkpointer


@struct.dataclass
class Stats:
    mean: jax.Array
    var: jax.Array
    count: jax.Array


@struct.dataclass
class FakeState:
    """Shaped like a TrainState: what ``policy_part`` reads, plus an env state with the leaf kinds
    MJX produces (bool, uint32 keys, zero-size contact arrays) and a static field."""

    params: dict
    obs_stats: Stats
    env_state: dict
    key: jax.Array
    iteration: jax.Array
    tag: str = struct.field(pytree_node=False, default="static")


def make_state(seed: int = 0, hidden: int = 4) -> FakeState:
    rng = np.random.default_rng(seed)
    return FakeState(
        params={"w": jnp.asarray(rng.normal(size=(3, hidden)), jnp.float32), "log_std": jnp.zeros(2)},
        obs_stats=Stats(mean=jnp.asarray(rng.normal(size=3), jnp.float32), var=jnp.ones(3), count=jnp.array(7.0)),
        env_state={
            "done": jnp.asarray(rng.random(5) > 0.5),
            "rng": jax.random.split(jax.random.PRNGKey(seed), 5),
            "contact": jnp.zeros((5, 0, 3)),
            "step": jnp.arange(5, dtype=jnp.int32),
        },
        key=jax.random.PRNGKey(seed + 1),
        iteration=jnp.array(seed, jnp.int32),
    )


def assert_same(a, b):
    la, lb = jax.tree.leaves(a), jax.tree.leaves(b)
    assert jax.tree.structure(a) == jax.tree.structure(b)
    for x, y in zip(la, lb, strict=True):
        assert x.dtype == y.dtype and x.shape == y.shape
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def listing(path: Path) -> dict:
    return {str(p.relative_to(path)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(path.rglob("*"))}


def test_round_trip_is_exact_and_needs_only_an_abstract_target(tmp_path):
    state = make_state(3)
    ckpt = Checkpointer(tmp_path / "ckpt", keep=3, create=True)
    ckpt.save(3, state, score=1.5, metrics={"return_mean_policy": 1.5, "kl": float("nan")}, info={"task": "t"})
    restored = ckpt.restore(jax.eval_shape(lambda: make_state(0)))
    assert_same(restored, state)
    assert restored.tag == "static"
    meta = ckpt.read_meta(3)
    assert meta["score"] == 1.5 and meta["metrics"]["kl"] is None and meta["task"] == "t"
    part = ckpt.restore_policy({"params": make_state(0).params, "obs_stats": make_state(0).obs_stats})
    assert_same(part["params"], state.params)
    assert_same(part["obs_stats"], state.obs_stats)


def test_retention_keeps_latest_k_and_best(tmp_path):
    ckpt = Checkpointer(tmp_path, keep=2, create=True)
    for step, score in zip([1, 2, 3, 4, 5], [5.0, 1.0, 2.0, 3.0, 0.0], strict=True):
        ckpt.save(step, make_state(step), score=score)
    assert ckpt.steps() == [1, 4, 5]
    assert ckpt.best_step() == 1 and ckpt.resolve_step("best") == 1 and ckpt.resolve_step(None) == 5
    assert_same(ckpt.restore(make_state(0), "best"), make_state(1))
    # A new best replaces the old one; NaN/None scores never win.
    ckpt.save(6, make_state(6), score=9.0)
    ckpt.save(7, make_state(7), score=float("nan"))
    assert ckpt.steps() == [6, 7]
    # A fresh reader sees the same best from the saved metadata.
    assert Checkpointer(tmp_path).best_step() == 6


def test_leftover_tmp_dir_of_an_interrupted_write_is_ignored(tmp_path):
    ckpt = Checkpointer(tmp_path, keep=3, create=True)
    ckpt.save(2, make_state(2))
    # What a process killed while writing step 4 leaves: a temporary directory, never renamed.
    tmp = tmp_path / "4.orbax-checkpoint-tmp-1700000000000000"
    (tmp / "state").mkdir(parents=True)
    (tmp / "state" / "garbage").write_bytes(os.urandom(64))
    reader = Checkpointer(tmp_path)
    assert reader.steps() == [2] and find_tmp_dirs(tmp_path) == [tmp]
    assert_same(reader.restore(make_state(0)), make_state(2))
    # Saving goes on around it.
    ckpt.save(4, make_state(4))
    assert_same(Checkpointer(tmp_path).restore(make_state(0)), make_state(4))


def test_missing_directory_is_an_error_and_is_not_created(tmp_path):
    with pytest.raises(CheckpointError, match="does not exist"):
        Checkpointer(tmp_path / "nope")
    assert not (tmp_path / "nope").exists()
    (tmp_path / "empty").mkdir()
    with pytest.raises(CheckpointError, match="no checkpoint"):
        Checkpointer(tmp_path / "empty").restore(make_state(0))
    ckpt = Checkpointer(tmp_path / "c", create=True)
    ckpt.save(1, make_state(1))
    with pytest.raises(CheckpointError, match="no checkpoint of step 9"):
        ckpt.restore(make_state(0), 9)
    with pytest.raises(CheckpointError, match="must be a number"):
        ckpt.restore(make_state(0), "first")


def test_incompatible_target_gives_one_clear_error(tmp_path):
    ckpt = Checkpointer(tmp_path, create=True)
    ckpt.save(1, make_state(1, hidden=4), info={"task": "hopper", "algo": "npg"})
    before = listing(tmp_path)
    with pytest.raises(CheckpointError, match=r"\['w'\] float32\[3, 4\] where .*\['w'\] float32\[3, 8\]") as e:
        ckpt.restore(make_state(0, hidden=8))
    assert "\n" not in str(e.value)
    with pytest.raises(CheckpointError, match="holds 11 arrays but this run's state has 10"):
        ckpt.restore(make_state(0).replace(key=None))
    with pytest.raises(CheckpointError, match="task 'hopper', this run's is 'cartpole'"):
        ckpt.restore(make_state(0), expect={"task": "cartpole", "algo": "npg"})
    assert listing(tmp_path) == before


def test_corrupt_checkpoint_gives_one_clear_error_and_touches_nothing(tmp_path, capsys):
    ckpt = Checkpointer(tmp_path, create=True)
    ckpt.save(1, make_state(1))
    ckpt.save(2, make_state(2))
    for path in (tmp_path / "2" / "state").rglob("*"):
        if path.is_file():
            path.write_bytes(b"\x00not a checkpoint" * 3)
    before = listing(tmp_path)
    # Asked for by number, a damaged step is an error, not replaced by another.
    with pytest.raises(CheckpointError, match="step 2 .* damaged") as e:
        Checkpointer(tmp_path).restore(make_state(0), 2)
    assert "\n" not in str(e.value)
    assert listing(tmp_path) == before
    # The latest usable checkpoint is the older one.
    assert_same(Checkpointer(tmp_path).restore(make_state(0)), make_state(1))
    assert capsys.readouterr().err.startswith("warning: checkpoint 2 is damaged (")
    shutil.rmtree(tmp_path / "1" / "meta")
    with pytest.raises(CheckpointError, match="step 1 .* unreadable"):
        Checkpointer(tmp_path).restore(make_state(0), 1)


# --------------------------------------------------------------------------- damage, commit markers, disk errors


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    """Checkpoints 2 and 4 of ``make_state``, written once; tests damage copies (``ckpts``)."""
    path = tmp_path_factory.mktemp("pristine") / "ckpt"
    ckpt = Checkpointer(path, keep=None, create=True)
    for step in (2, 4):
        ckpt.save(step, make_state(step), score=float(step), info={"task": "t", "algo": "a"})
    ckpt.close()
    return path


@pytest.fixture
def ckpts(pristine, tmp_path):
    path = tmp_path / "ckpt"
    shutil.copytree(pristine, path)
    return path


def data_files(item: Path) -> list[Path]:
    """The files holding an Orbax item's array data (OCDBT data files, not its metadata)."""
    files = sorted(p for p in item.rglob("*") if p.is_file() and p.parent.name == "d")
    assert files
    return files


def truncate_state(step: Path) -> None:
    for path in data_files(step / "state"):
        path.write_bytes(path.read_bytes()[:20])


def delete_state_file(step: Path) -> None:
    for path in data_files(step / "state"):
        path.unlink()


def garble_meta(step: Path) -> None:
    (step / "meta" / "metadata").write_text('{"step": 4, "sco')


def truncate_manifest(step: Path) -> None:
    path = step / "state" / "manifest.ocdbt"
    path.write_bytes(path.read_bytes()[:10])


def garble_state_metadata(step: Path) -> None:
    (step / "state" / "_METADATA").write_text("{")


def remove_policy(step: Path) -> None:
    shutil.rmtree(step / "policy")


DAMAGE = {
    "truncated state file": (truncate_state, r"its state item is unreadable: out of range: 4/state/d/\w+"),
    "deleted state file": (delete_state_file, r"its state item is unreadable: not found: 4/state/d/\w+"),
    "damaged meta JSON": (garble_meta, r"its meta item is unreadable: JSONDecodeError: "),
    "damaged OCDBT manifest": (truncate_manifest, r"its state item is unreadable: "),
    "damaged item metadata": (garble_state_metadata, r"its state item is unreadable: JSONDecodeError: "),
    "missing policy item": (remove_policy, r"its policy item is missing"),
}


def one_warning(err: str, reason: str, bad: int = 4, used: int = 2) -> None:
    """``err`` is exactly one line: the warning that ``bad`` was skipped for ``reason``."""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert re.fullmatch(rf"warning: checkpoint {bad} is damaged \({reason}.*\); using checkpoint {used}", lines[0])
    assert len(lines[0]) < 300


@pytest.mark.parametrize("damage", DAMAGE, ids=list(DAMAGE))
def test_damaged_latest_falls_back_with_one_warning(ckpts, damage, capfd):
    damage_fn, reason = DAMAGE[damage]
    damage_fn(ckpts / "4")
    before = listing(ckpts)
    # What --resume does: latest_step(), then restore that step.
    reader = Checkpointer(ckpts, keep=None)
    step = reader.latest_step()
    assert step == 2
    assert_same(reader.restore(make_state(0), step, expect={"task": "t", "algo": "a"}), make_state(2))
    reader.close()
    one_warning(capfd.readouterr().err, reason)
    # What load_policy does: resolve "latest", restore the policy item; "best" falls back too.
    reader = Checkpointer(ckpts, keep=None)
    part = reader.restore_policy(policy_part(make_state(0)))
    assert_same(part, policy_part(make_state(2)))
    one_warning(capfd.readouterr().err, reason)
    assert Checkpointer(ckpts).resolve_step("best") == 2
    if damage == "damaged meta JSON":  # no score: never the best candidate, so never skipped
        assert capfd.readouterr().err == ""
    else:
        one_warning(capfd.readouterr().err, reason)
    assert listing(ckpts) == before


def test_damaged_step_asked_for_by_number_is_one_line_error(ckpts, capfd):
    truncate_state(ckpts / "4")
    before = listing(ckpts)
    with pytest.raises(CheckpointError) as e:
        Checkpointer(ckpts).restore(make_state(0), 4)
    message = str(e.value)
    assert re.fullmatch(
        r"checkpoint step 4 in \S+ is damaged \(its state item is unreadable: out of range: 4/state/d/\w+\); "
        r"steps: \[2, 4\]",
        message,
    ), message
    assert "tensorstore" not in message.lower() and len(message) < 300
    assert capfd.readouterr().err == ""  # no Orbax/absl log lines, no asyncio tracebacks
    assert listing(ckpts) == before


def test_uncommitted_step_directories_are_never_latest(ckpts, capfd):
    # A step directory without Orbax's commit marker (an interrupted copy, a write that never
    # finished on a file system without renames) and a temporary directory of an unfinished write.
    shutil.copytree(ckpts / "4", ckpts / "6")
    (ckpts / "6" / "commit_success.txt").unlink()
    (ckpts / "6" / "_CHECKPOINT_METADATA").unlink()
    shutil.copytree(ckpts / "4", ckpts / "8.orbax-checkpoint-tmp-1700000000000000")
    before = listing(ckpts)
    reader = Checkpointer(ckpts)
    assert reader.steps() == [2, 4] and reader.latest_step() == 4 and reader.best_step() == 4
    assert_same(reader.restore(make_state(0)), make_state(4))
    assert capfd.readouterr().err == ""
    assert listing(ckpts) == before
    # Saving that step replaces the uncommitted directory.
    writer = Checkpointer(ckpts, keep=None)
    writer.save(6, make_state(6))
    assert writer.steps() == [2, 4, 6]
    assert_same(Checkpointer(ckpts).restore(make_state(0)), make_state(6))


def test_no_readable_checkpoint_is_one_line_error_saying_what_to_do(ckpts, capfd):
    truncate_state(ckpts / "4")
    remove_policy(ckpts / "2")
    before = listing(ckpts)
    for call in (lambda c: c.latest_step(), lambda c: c.restore(make_state(0)), lambda c: c.resolve_step("best")):
        with pytest.raises(CheckpointError) as e:
            call(Checkpointer(ckpts))
        message = str(e.value)
        assert re.fullmatch(
            r"no checkpoint in \S+ reads back completely \(checkpoint 4 and 1 older one\(s\) damaged: its state item "
            r"is unreadable: out of range: 4/state/d/\w+\); train the run again \(a new --run-dir, or --overwrite "
            r"to replace this one\)",
            message,
        ), message
    assert capfd.readouterr().err == ""
    assert listing(ckpts) == before


@pytest.mark.parametrize(
    ("code", "message"),
    [
        (errno.ENOSPC, "the disk is full; free some space .*then continue with --resume"),
        (errno.EACCES, "permission denied; make the directory writable for this user, or choose another --run-dir"),
        (errno.EROFS, r"the file system is read-only; write the run to a writable place \(--run-dir\)"),
    ],
)
def test_disk_full_or_unwritable_save_is_one_line_error(ckpts, monkeypatch, code, message):
    import orbax.checkpoint as ocp

    before = listing(ckpts)
    save = ocp.CheckpointManager.save

    def failing_save(manager, step, *args, **kwargs):
        save(manager, step, *args, **kwargs)  # a step half written, then the disk error
        raise OSError(code, os.strerror(code), str(ckpts / str(step) / "state"))

    monkeypatch.setattr(ocp.CheckpointManager, "save", failing_save)
    writer = Checkpointer(ckpts, keep=1)
    with pytest.raises(CheckpointError, match=rf"^cannot save checkpoint 6 in \S+ \(\S+/6/state\): {message}$") as e:
        writer.save(6, make_state(6))
    assert isinstance(e.value, ValueError) and "\n" not in str(e.value)
    # The failed step is cleaned up; the earlier checkpoints are untouched (no retention ran).
    assert listing(ckpts) == before
    assert writer.steps() == [2, 4] and find_tmp_dirs(ckpts) == []


def test_unwritable_directory_deep_in_orbax_is_one_line_error(tmp_path, monkeypatch):
    """As root chmod stops nothing: directories cannot be made, wherever Orbax makes them."""
    mkdir = os.mkdir

    def denied(path, *args, **kwargs):
        if str(path).startswith(str(tmp_path)):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return mkdir(path, *args, **kwargs)

    monkeypatch.setattr(os, "mkdir", denied)
    with pytest.raises(CheckpointError, match=r"^cannot create checkpoint directory \S+: permission denied; ") as e:
        Checkpointer(tmp_path / "new", create=True)
    assert "\n" not in str(e.value)
    monkeypatch.setattr(os, "mkdir", mkdir)
    writer = Checkpointer(tmp_path / "c", create=True)
    writer.save(1, make_state(1))
    monkeypatch.setattr(os, "mkdir", denied)
    with pytest.raises(CheckpointError, match=r"^cannot save checkpoint 2 in \S+( \(\S+\))?: permission denied; "):
        writer.save(2, make_state(2))
    monkeypatch.setattr(os, "mkdir", mkdir)
    assert writer.steps() == [1] and find_tmp_dirs(tmp_path / "c") == []


def test_save_reads_the_policy_back_and_removes_a_step_that_does_not(ckpts, monkeypatch):
    import orbax.checkpoint as ocp

    before = listing(ckpts)
    save = ocp.CheckpointManager.save

    def lossy_save(manager, step, *args, **kwargs):
        save(manager, step, *args, **kwargs)
        for path in data_files(ckpts / str(step) / "policy"):  # a write the file system lost
            path.write_bytes(b"")

    monkeypatch.setattr(ocp.CheckpointManager, "save", lossy_save)
    writer = Checkpointer(ckpts, keep=1)
    with pytest.raises(CheckpointError) as e:
        writer.save(6, make_state(6))
    assert re.fullmatch(
        r"checkpoint 6 in \S+ did not read back after saving \(its policy item is unreadable: .*\) and was removed; "
        r"check the disk \(free space, errors\), then continue with --resume",
        str(e.value),
    ), str(e.value)
    assert listing(ckpts) == before and writer.steps() == [2, 4]


def test_disk_full_reported_as_text_by_tensorstore_is_recognised(ckpts, monkeypatch):
    import orbax.checkpoint as ocp

    spec = '{"driver": "zarr", "kvstore": {"driver": "ocdbt"}} ' * 40

    def failing_save(manager, step, *args, **kwargs):
        raise ValueError(f"RESOURCE_EXHAUSTED: Error writing local file: [OS error 28: No space left on device] {spec}")

    monkeypatch.setattr(ocp.CheckpointManager, "save", failing_save)
    with pytest.raises(CheckpointError, match=r"^cannot save checkpoint 6 in \S+: the disk is full; [^\n]*--resume$"):
        Checkpointer(ckpts).save(6, make_state(6))


def test_failed_reads_print_nothing_later(tmp_path, capfd, monkeypatch):
    """TensorStore reads still in flight when an Orbax restore fails complete on a closed asyncio
    loop; their tracebacks ("Event loop is closed") are not printed."""
    import gc
    import sys
    import time

    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)  # what would be printed

    state = make_state(1).replace(env_state={f"a{i}": jnp.full((50, i + 1), float(i)) for i in range(60)})
    Checkpointer(tmp_path, create=True).save(4, state)
    for path in data_files(tmp_path / "4" / "state"):
        path.write_bytes(path.read_bytes()[:20])
    for _ in range(3):
        with pytest.raises(CheckpointError, match="step 4 .* damaged"):
            Checkpointer(tmp_path).restore(state, 4)
    time.sleep(0.5)
    gc.collect()
    assert capfd.readouterr().err == "" and unraisable == []
