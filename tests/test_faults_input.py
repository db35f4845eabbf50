"""Nothing lost, nothing silent, for input: every bad value on the command line, in a run's
``config.json`` or in the environment is one ``error:`` line with exit status 2 (or, for an
optional cache, one ``warning:`` line), before anything is compiled or written.

Refusals are checked for their status, a single line with the expected text, and that nothing was
created or changed. The command lines run in this process and stop before compiling; only the
``JAX_PLATFORMS`` case needs a process of its own."""

from __future__ import annotations

import hashlib
import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import script_loader

import jaxpg
from jaxpg import algos, envs
from jaxpg.algos import core
from jaxpg.run.command import command_line, main, planning
from jaxpg.run.command.flags import UsageError
from jaxpg.run.evaluation import evaluate_cli
from jaxpg.run.host import compile_cache
from jaxpg.run.rundir import config_io, layout

ROOT = Path(__file__).resolve().parent.parent


def digest(path: Path) -> dict[str, str]:
    files = (p for p in path.rglob("*") if p.is_file())
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


def one_error(capsys, expected: str) -> str:
    """The single stderr line, which must start with ``error: `` and contain ``expected``."""
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and expected in lines[0], err
    return lines[0]


# --------------------------------------------------------------------------- flags

BAD_FLAGS = [
    (["--kl-delta", "inf"], "argument --kl-delta: must be a finite number, got inf"),
    (["--kl-delta=-inf"], "argument --kl-delta: must be a finite number, got -inf"),
    (["--kl-delta", "nan"], "argument --kl-delta: must be a finite number, got nan"),
    (["--algo", "ppo", "--lr", "inf"], "argument --lr: must be a finite number, got inf"),
    (["--algo", "ppo", "--lr", "Infinity"], "argument --lr: must be a finite number, got Infinity"),
    (["--gamma", "inf"], "argument --gamma: must be a finite number, got inf"),
    (["--minutes", "inf"], "argument --minutes: must be a finite number, got inf"),
    (["--seed", "99999999999999999999"], "argument --seed: must be an integer in [0, 4294967295]"),
    (["--seed", "-1"], "argument --seed: must be an integer in [0, 4294967295]"),
    (["--seeds", "1", "4294967296"], "argument --seeds: must be an integer in [0, 4294967295]"),
    (["--keep-checkpoints", "0"], "argument --keep-checkpoints: must be >= 1"),
]


@pytest.mark.parametrize(("flags", "message"), BAD_FLAGS, ids=[" ".join(f) for f, _ in BAD_FLAGS])
def test_bad_flags_are_one_line_and_write_nothing(flags, message, tmp_path, capsys):
    run_dir = tmp_path / "new"
    status = main.main(["--env", "inverted_pendulum", "--iterations", "2", "--run-dir", str(run_dir), *flags])
    one_error(capsys, message)
    assert status == 2
    assert not run_dir.exists()


TOO_LARGE = [
    # Rollout of 10^12 envs x 128 steps, 9 float32 numbers per sample: 4.1 PiB.
    (["--num-envs", "1000000000000"], "needs at least 4.1 PiB of memory"),
    # 10^12 weights of the value network's second layer: 3.6 TiB.
    (["--value-hidden", "1000000", "1000000"], "needs at least 3.6 TiB of memory"),
    (["--policy-hidden", "10000000", "10000000"], "needs at least 363.8 TiB of memory"),
]


@pytest.mark.parametrize(("flags", "message"), TOO_LARGE, ids=[" ".join(f) for f, _ in TOO_LARGE])
def test_sizes_that_cannot_fit_in_memory_are_refused_when_planning(flags, message, tmp_path):
    """``plan`` (not ``main``: were the check missing, main would try to train them) refuses them
    in one line saying what is needed, what there is and what to lower."""
    argv = ["--env", "inverted_pendulum", "--run-dir", str(tmp_path / "new"), *flags]
    with pytest.raises(UsageError) as e:
        planning.plan(argv, command_line.Experiment())
    line = str(e.value)
    assert "\n" not in line and message in line, line
    assert re.search(
        r"but (this host|each .+) has [\d.]+ [KMGTP]?i?B available; lower --num-envs, --horizon or the network", line
    )
    assert not (tmp_path / "new").exists()


def test_memory_lower_bound_counts_parameters_and_the_rollout_by_hand():
    """inverted_pendulum: 4 observations, 1 action. Policy 4-8-1 with a log-std per action:
    (4*8 + 8) + (8*1 + 1) + 1 = 50 numbers; value 4-8-1: (4*8 + 8) + (8 + 1) = 49; float32."""
    env = envs.make("inverted_pendulum")
    config = algos.get("npg").Config(num_envs=16, horizon=10, policy_hidden=(8,), value_hidden=(8,), eval_envs=0)
    bound = core.memory_lower_bound(config, env)
    assert bound["parameters"] == 4 * (50 + 49)
    # Each of the 16 x 10 samples holds its observation, action, reward, done, log-prob and value.
    assert bound["rollout"] == 4 * 16 * 10 * (4 + 1 + 4)
    assert bound["total"] == bound["parameters"] + bound["rollout"] + bound["env_states"]
    assert bound["env_states"] >= 4 * 16 * 4  # at least each env's observation


def test_long_run_directory_names_are_one_line(tmp_path, capsys):
    long = tmp_path / ("a" * 300)
    assert main.main(["--iterations", "2", "--run-dir", str(long)]) == 2
    one_error(capsys, "--run-dir: a name in")
    assert main.main(["--resume", str(long)]) == 2
    one_error(capsys, "--resume: a name in")
    assert evaluate_cli.main([str(long), "--episodes", "1"]) == 2
    one_error(capsys, "a name in")
    with pytest.raises(layout.RunDirError, match="longer than the"):
        jaxpg.load_policy(long)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- config.json


@pytest.fixture
def run_dir(tmp_path) -> Path:
    """A run directory as a run's start writes it (config.json, no checkpoint yet)."""
    config = algos.get("npg").Config(num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), value_batch_size=8)
    run = config_io.RunConfig(
        task="cartpole", algo="npg", config=config_io.config_to_dict(config), seeds=[0], iterations=4
    )
    path = tmp_path / "run"
    path.mkdir()
    run.save(path)
    return path


def edit_config(run_dir: Path, edit) -> None:
    data = json.loads((run_dir / layout.CONFIG_FILE).read_text())
    edit(data)
    (run_dir / layout.CONFIG_FILE).write_text(json.dumps(data))


BAD_CONFIGS = {
    "num_envs abc": (lambda d: d["config"].update(num_envs="abc"), "field num_envs must be an integer, got 'abc'"),
    "kl_delta true": (lambda d: d["config"].update(kl_delta=True), "field kl_delta must be a number, got True"),
    "kl_delta Infinity": (lambda d: d["config"].update(kl_delta=float("inf")), "kl_delta must be a finite number"),
    "policy_hidden 8": (
        lambda d: d["config"].update(policy_hidden=8),
        "field policy_hidden must be a list of integers, got 8",
    ),
    "seeds zero": (lambda d: d.update(seeds="zero"), "seeds must be a list of integers, got 'zero'"),
    "seeds huge": (lambda d: d.update(seeds=[2**40]), "seeds must be integers in [0, 4294967295], got 1099511627776"),
    "iterations many": (lambda d: d.update(iterations="many"), "iterations must be an integer, got 'many'"),
    "env_kwargs list": (lambda d: d.update(env_kwargs=[]), "env_kwargs must be an object, got []"),
    "num_envs huge": (lambda d: d["config"].update(num_envs=10**12), "lower --num-envs, --horizon or the network"),
    # The schedule by the rules of its flags (--keep-checkpoints >= 1, --checkpoint-every >= 0, ...).
    "keep_checkpoints 0": (lambda d: d.update(keep_checkpoints=0), "keep_checkpoints must be >= 1, got 0"),
    "checkpoint_every -1": (lambda d: d.update(checkpoint_every=-1), "checkpoint_every must be >= 0, got -1"),
    "video_every -3": (lambda d: d.update(video_every=-3), "video_every must be >= 0, got -3"),
    "format true": (lambda d: d.update(format=True), "format must be an integer >= 1, got true"),
    "unknown key": (lambda d: d.update(keep_best=True), "unknown key keep_best"),
    # Task options by the rules of --env-kwargs: before, a string here failed at trace time.
    "env_kwargs type": (
        lambda d: d.update(env_kwargs={"reset_bound": "wide"}),
        "env_kwargs: task option reset_bound must be a number, got 'wide'",
    ),
    "env_kwargs unknown": (lambda d: d.update(env_kwargs={"bogus": 1}), "task 'cartpole' has no option 'bogus'"),
}


@pytest.mark.parametrize("case", BAD_CONFIGS, ids=list(BAD_CONFIGS))
def test_bad_config_json_is_one_line_in_resume_evaluate_and_load_policy(case, run_dir, capsys):
    edit, message = BAD_CONFIGS[case]
    edit_config(run_dir, edit)
    before = digest(run_dir)
    assert main.main(["--resume", str(run_dir)]) == 2
    one_error(capsys, message)
    if case not in ("num_envs huge", "kl_delta Infinity"):  # evaluation reads neither field
        assert evaluate_cli.main([str(run_dir), "--episodes", "1"]) == 2
        one_error(capsys, message)
        with pytest.raises(ValueError, match="^[^\n]*$"):
            jaxpg.load_policy(run_dir)
    assert digest(run_dir) == before


def test_each_bad_value_of_config_json_is_one_error_line(run_dir, capsys):
    """Several hand-edited values: ``--resume`` names each on its own ``error:`` line (exit 2), and
    ``load_policy`` raises one one-line error naming them all; nothing changes."""
    edit_config(run_dir, lambda d: d.update(keep_checkpoints=0, video_every=-3, iterations="many"))
    before = digest(run_dir)
    assert main.main(["--resume", str(run_dir)]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 3 and all(line.startswith("error: ") for line in lines), lines
    for part in ("iterations must be an integer", "keep_checkpoints must be >= 1", "video_every must be >= 0"):
        assert sum(part in line for line in lines) == 1, lines
    with pytest.raises(ValueError, match="^[^\n]*keep_checkpoints must be >= 1[^\n]*$"):
        jaxpg.load_policy(run_dir)
    assert digest(run_dir) == before


# --------------------------------------------------------------------------- evaluate --video, caches, platforms


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc, where no file can be created")
def test_unwritable_video_path_is_refused_before_evaluating(run_dir, tmp_path, capsys):
    """The run has no checkpoint: an error about the video (not the checkpoint) shows the path was
    checked first. /proc refuses new files even to root; a path under a file is no directory."""
    (tmp_path / "file").write_text("x")
    for path, reason in (
        ("/proc/jaxpg-out.mp4", "cannot write"),
        (str(tmp_path / "file" / "out.mp4"), "not a directory"),
    ):
        assert evaluate_cli.main([str(run_dir), "--video", path]) == 2
        line = one_error(capsys, f"--video {path}: ")
        assert reason in line, line
    assert (tmp_path / "file").read_text() == "x"


def test_unusable_compilation_cache_is_one_warning_line(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    for path in (tmp_path / "file" / "cache", Path("/proc")):
        assert compile_cache.enable(path) is None
        err = capsys.readouterr().err.splitlines()
        assert len(err) == 1 and err[0].startswith(f"warning: compilation cache {path} is not usable ("), err
        assert err[0].endswith("; compiling without it (set JAXPG_COMPILATION_CACHE to a writable directory, or off)")
    good = tmp_path / "cache"
    assert compile_cache.enable(good) == good and capsys.readouterr().err == ""


PLATFORM_SCRIPT = textwrap.dedent(
    """
    import sys
    from jaxpg.run.evaluation import evaluate_cli
    from jaxpg.run.command import command_line, main, planning
    print(main.main(["--iterations", "1", "--run-dir", sys.argv[1] + "/new"]))
    print(evaluate_cli.main([sys.argv[1] + "/run", "--episodes", "1"]))
    """
)


def test_unavailable_jax_platform_is_one_line(run_dir, tmp_path):
    env = {**os.environ, "JAX_PLATFORMS": "cuda", "PYTHONPATH": script_loader.python_path()}
    proc = subprocess.run(
        [sys.executable, "-c", PLATFORM_SCRIPT, str(tmp_path)], capture_output=True, text=True, env=env, timeout=600
    )
    assert proc.stdout.split() == ["2", "2"], proc.stdout + proc.stderr[-3000:]
    lines = proc.stderr.splitlines()
    assert len(lines) == 2, proc.stderr[-3000:]
    for line in lines:
        assert line.startswith("error: JAX cannot use the platform JAX_PLATFORMS=cuda asks for ("), line
    assert not (tmp_path / "new").exists()


def test_non_finite_floats_in_a_config_are_refused_by_validate():
    env = envs.make("inverted_pendulum")
    for name, value in (("kl_delta", np.inf), ("cg_damping", -np.inf), ("gamma", np.nan)):
        config = algos.get("npg").Config(**{name: value})
        with pytest.raises(ValueError, match=f"^{name} must be a finite number, got {value}$"):
            config.validate(env)


# --------------------------------------------------------------------------- interrupts

STUCK_SCRIPT = textwrap.dedent(
    """
    import sys
    import jax
    from jaxpg.run.command import command_line, main, planning
    from jaxpg.run.training import session

    def stuck(*args, **kwargs):
        # float32 x stops growing at 2**24 and stays >= 0: a compiled call that never returns.
        loop = jax.jit(lambda: jax.lax.while_loop(lambda x: x >= 0, lambda x: x + 1.0, 0.0))
        compiled = loop.lower().compile()
        print("stuck", flush=True)
        jax.block_until_ready(compiled())

    session.initial_state = stuck
    sys.exit(main.main(["--env", "inverted_pendulum", "--iterations", "2", "--run-dir", sys.argv[1]]))
    """
)


def test_a_run_stuck_in_a_compiled_call_still_stops_on_sigint(tmp_path):
    """Python cannot run its signal handler while the main thread waits in a compiled call; the
    watcher thread ends the process once the handler has not run for a few seconds."""
    run_dir = tmp_path / "run"
    env = {**os.environ, "PYTHONPATH": script_loader.python_path()}
    proc = subprocess.Popen(
        [sys.executable, "-c", STUCK_SCRIPT, str(run_dir)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        lines = []
        while not lines or lines[-1] != "stuck":
            line = proc.stdout.readline()
            assert line, "the process ended before its compiled call: " + proc.stderr.read()[-3000:]
            lines.append(line.strip())
        time.sleep(0.5)  # into the compiled call
        proc.send_signal(signal.SIGINT)
        # A guard against a hang, not a speed requirement: the watcher acts after 5 s.
        _, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail("SIGINT did not stop a run stuck in a compiled call")
    assert proc.returncode == 130, err[-3000:]
    assert err.splitlines()[-1].startswith("SIGINT: stopped at once: a compiled call or compilation did not return")
    assert not run_dir.exists()  # the state is built before the run directory is touched


# --------------------------------------------------------------------------- one line, not a traceback


def test_a_task_whose_simulator_is_not_installed_is_one_line(tmp_path, monkeypatch, capsys):
    """``--env atari_pong`` without ale-py (``import ale_py`` fails): one ``error:`` line naming
    the install, as ``evaluate --ale`` says it, and nothing written."""
    monkeypatch.setitem(sys.modules, "ale_py", None)  # `import ale_py` raises ImportError
    assert main.main(["--env", "atari_pong", "--iterations", "1", "--run-dir", str(tmp_path / "run")]) == 2
    one_error(capsys, "atari_pong needs the Arcade Learning Environment (ale-py): pip install")
    assert list(tmp_path.iterdir()) == []


def test_an_invalid_mujoco_gl_is_one_line(tmp_path, monkeypatch, capsys):
    """MuJoCo refuses an unknown ``MUJOCO_GL`` with a traceback at its first import, video or not:
    checked first, one ``error:`` line; the values MuJoCo takes pass, in any case."""
    from jaxpg.run.command import startup

    for good in ("egl", " OSMesa ", "off", ""):
        startup.check_mujoco_gl({"MUJOCO_GL": good}, system="Linux")
    startup.check_mujoco_gl({}, system="Linux")
    with pytest.raises(UsageError, match="^MUJOCO_GL=wgl is not a value MuJoCo accepts"):
        startup.check_mujoco_gl({"MUJOCO_GL": "wgl"}, system="Linux")
    monkeypatch.setenv("MUJOCO_GL", "bogus")
    assert main.main(["--env", "inverted_pendulum", "--iterations", "1", "--run-dir", str(tmp_path / "run")]) == 2
    one_error(capsys, "MUJOCO_GL=bogus is not a value MuJoCo accepts")
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- benchmarks/suite.py


def test_suite_help_and_unknown_runs(tmp_path):
    """``suite.py --help`` prints the modes with exit status 0; ``run`` with an unknown task or a
    preset the algorithm lacks is refused before any run starts: one ``error:`` line each, exit 2."""
    env = {**os.environ, "PYTHONPATH": script_loader.python_path()}
    script = str(script_loader.ROOT / "benchmarks" / "suite.py")
    shown = subprocess.run([sys.executable, script, "--help"], capture_output=True, text=True, env=env, timeout=600)
    assert shown.returncode == 0 and "Four modes" in shown.stdout, shown.stderr[-2000:]
    runs = ["--runs", "nope:npg:x", "hopper:npg:no_such_preset", "--episodes", "0", "--out", str(tmp_path / "out")]
    refused = subprocess.run(
        [sys.executable, script, "run", *runs], capture_output=True, text=True, env=env, timeout=600
    )
    lines = refused.stderr.splitlines()
    assert refused.returncode == 2, refused.stderr[-2000:]
    assert len(lines) == 2 and lines[0].startswith("error: nope:npg:x: unknown task 'nope'"), lines
    assert lines[1].startswith("error: hopper:npg:no_such_preset: npg has no preset 'no_such_preset' for hopper"), lines
    assert not (tmp_path / "out").exists()


def test_suite_json_has_no_nan_and_failed_runs_are_named():
    """A run that never scored: its NaN figures are written as null (JSON has no NaN), and the
    failures (exit status, no Gymnasium score) are listed for the ``error:`` lines and exit 1."""
    verdicts = script_loader.load_script("benchmarks/suite.py").verdicts
    rows = [
        {"task": "hopper", "algo": "npg", "preset": "p", "seed": 0, "status": 2, "run_dir": "r0", "env_steps": np.nan},
        {
            "task": "hopper",
            "algo": "npg",
            "preset": "p",
            "seed": 1,
            "status": 0,
            "run_dir": "r1",
            "gymnasium_return": None,
        },
        {
            "task": "hopper",
            "algo": "npg",
            "preset": "p",
            "seed": 2,
            "status": 0,
            "run_dir": "r2",
            "gymnasium_return": 0.0,
        },
    ]
    text = json.dumps(verdicts.finite_or_none({"rows": rows, "summary": [{"median": float("nan"), "scores": []}]}))
    assert "NaN" not in text and json.loads(text)["rows"][0]["env_steps"] is None
    failed = verdicts.failures(rows, episodes=10)
    assert len(failed) == 2 and "seed 0: exit status 2" in failed[0] and "seed 1: no Gymnasium score" in failed[1]
    assert verdicts.failures(rows[1:], episodes=0) == []


def test_options_a_task_forwards_to_another_class_are_checked_as_that_class_takes_them():
    """``pong`` is ``DifferencePong``, whose ``**pong_kwargs`` build ``Pong``: a ``config.json`` or
    ``--env-kwargs`` option of ``Pong``'s is accepted with its type, a wrong type or an unknown name
    is one line naming it (found when a run directory of the Pong experiment was resumed)."""
    from jaxpg.envs.pong import Pong
    from jaxpg.run.command import task_options

    assert task_options.check_options("pong", {"size": 40, "first": "zeros"}) == {"size": 40, "first": "zeros"}
    assert set(task_options.option_types("pong")) >= {"first", "size", "stay_action", "winning_score"}
    assert "size" in Pong.__init__.__code__.co_varnames
    with pytest.raises(ValueError, match="^task option size must be an integer, got 'big'$"):
        task_options.check_options("pong", {"size": "big"})
    with pytest.raises(ValueError, match="^task 'pong' has no option 'sizes'; its options: first, size,"):
        task_options.check_options("pong", {"sizes": 40})
