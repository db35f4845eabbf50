"""jaxpg.load_policy, python -m jaxpg.evaluate and --resume with damaged checkpoints, observations
with NaN/inf and a path that is a file. One cartpole NPG run directory is written once per module
from the algorithm's ``init`` (checkpoints 2 and 4, nothing trained); tests damage copies of it."""

import json
import re
import shutil
from pathlib import Path

import jax
import numpy as np
import pytest

import jaxpg
from jaxpg import algos
from jaxpg.run import command_line, config_io, evaluate_cli, layout, main, planning, policy_io
from jaxpg.run.checkpoint_errors import CheckpointError
from jaxpg.run.checkpointer import Checkpointer


def listing(path: Path) -> dict:
    return {str(p.relative_to(path)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(path.rglob("*"))}


def shifted(ts, step: int):
    """``ts`` with the policy parameters moved by ``step``, so that each checkpoint differs."""
    return ts.replace(params=jax.tree.map(lambda x: x + 0.01 * step, ts.params))


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    module = algos.get("npg")
    config = module.Config(num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), value_batch_size=8)
    run = config_io.RunConfig(
        task="cartpole",
        algo="npg",
        config=config_io.config_to_dict(config),
        seeds=[0],
        iterations=4,
        checkpoint_every=2,
    )
    run_dir = tmp_path_factory.mktemp("runs") / "run"
    run_dir.mkdir()
    run.save(run_dir)
    # A resume needs the metrics of the iterations its checkpoint holds.
    rows = [{"iteration": i, "seed": 0, "env_steps": 32.0 * i, "wall_time_s": float(i)} for i in range(1, 5)]
    (run_dir / layout.METRICS_FILE).write_text("".join(json.dumps(r) + "\n" for r in rows))
    ts = module.init(jax.random.PRNGKey(0), run.make_env(), config)
    ckpt = Checkpointer(run_dir / layout.CHECKPOINT_DIR, keep=None, create=True)
    for step in (2, 4):
        ckpt.save(step, shifted(ts, step), score=float(step), info={"task": run.task, "algo": run.algo, "seeds": [0]})
    ckpt.close()
    return run_dir, ts


@pytest.fixture
def run_dir(pristine, tmp_path):
    path = tmp_path / "run"
    shutil.copytree(pristine[0], path)
    return path


def truncate_state(run_dir: Path, step: int) -> None:
    files = [p for p in (run_dir / "checkpoints" / str(step) / "state").rglob("*") if p.parent.name == "d"]
    assert files
    for path in files:
        path.write_bytes(path.read_bytes()[:20])


WARNING = re.compile(
    r"warning: checkpoint 4 is damaged \(its state item is unreadable: out of range: 4/state/d/\w+\); "
    r"using checkpoint 2"
)


def test_load_policy_falls_back_to_the_newest_readable_checkpoint(pristine, run_dir, capfd):
    truncate_state(run_dir, 4)
    before = listing(run_dir)
    policy = jaxpg.load_policy(run_dir)
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1 and WARNING.fullmatch(err[0]), err
    assert policy.step == 2
    expected = shifted(pristine[1], 2).params
    for got, want in zip(jax.tree.leaves(policy.params), jax.tree.leaves(expected), strict=True):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    assert listing(run_dir) == before


def test_resume_falls_back_to_the_newest_readable_checkpoint(pristine, run_dir, capfd):
    (run_dir / "checkpoints" / "4" / "meta" / "metadata").write_text("{")
    before = listing(run_dir)
    plan = planning.plan(["--resume", str(run_dir), "--iterations", "6"], command_line.Experiment())
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1 and re.fullmatch(
        r"warning: checkpoint 4 is damaged \(its meta item is unreadable: JSONDecodeError: .*\); using checkpoint 2",
        err[0],
    ), err
    assert plan.start == 2
    for got, want in zip(jax.tree.leaves(plan.state), jax.tree.leaves(shifted(pristine[1], 2)), strict=True):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    assert listing(run_dir) == before


def test_no_readable_checkpoint_is_one_error_line(run_dir, capfd):
    truncate_state(run_dir, 4)
    shutil.rmtree(run_dir / "checkpoints" / "2" / "policy")
    before = listing(run_dir)
    message = r"no checkpoint in \S+ reads back completely \(.*\); train the run again \(a new --run-dir, or "
    with pytest.raises(CheckpointError, match=message):
        jaxpg.load_policy(run_dir)
    assert capfd.readouterr().err == ""
    assert main.main(["--resume", str(run_dir)]) == 2
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1 and re.match("error: " + message, err[0]), err
    assert listing(run_dir) == before


def test_policy_rejects_observations_with_nan_or_inf(run_dir):
    policy = jaxpg.load_policy(run_dir)
    obs = np.zeros((3, policy.observation_size), np.float32)
    assert policy(obs).shape[0] == 3
    obs[1, 2] = np.nan
    with pytest.raises(ValueError, match=r"^observation contains NaN or inf \(obs\[1, 2\] = nan\); "):
        policy(obs)
    with pytest.raises(ValueError, match=r"^observation contains NaN or inf \(obs\[0\] = -inf\); "):
        policy(np.full(policy.observation_size, -np.inf))


def test_a_file_is_not_a_run_directory(run_dir, capsys):
    path = run_dir / "config.json"
    with pytest.raises(layout.RunDirError, match=r"^'\S+config.json' is a file, not a run directory"):
        jaxpg.load_policy(path)
    with pytest.raises(layout.RunDirError, match="is a file, not a run directory"):
        policy_io.restore_train_state(path)
    assert evaluate_cli.main([str(path), "--episodes", "1"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "is a file, not a run directory" in err[0]
