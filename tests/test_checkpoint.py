"""jaxpg.checkpoint: exact round trips, retention (latest k + best), and one clear error for
missing, corrupt, interrupted or incompatible checkpoints. Synthetic pytrees: nothing compiles."""

import os
import shutil
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from flax import struct

from jaxpg.checkpoint import Checkpointer, CheckpointError, find_tmp_dirs


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
