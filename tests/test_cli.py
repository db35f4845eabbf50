"""The host-side product: command line, run directory, resume, load_policy, evaluate, videos.

One tiny inverted-pendulum NPG configuration is trained once per module (``trained``) and every
test reuses its run directory and, in-process, its compiled programs (the CLI caches env objects,
so a resume or a second run hits jit's cache). Bad-input tests fail before anything compiles.
"""

import dataclasses
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import imageio.v2 as imageio
import mujoco
import numpy as np
import pytest
from script_loader import load_script

import jaxpg
from jaxpg.run.checkpoints import policy_io
from jaxpg.run.command import command_line, main, planning, pre_flags
from jaxpg.run.command import startup as startup_module
from jaxpg.run.command.flags import UsageError
from jaxpg.run.command.plan import Plan
from jaxpg.run.evaluation import evaluate_cli
from jaxpg.run.host import provenance
from jaxpg.run.outputs import console, metrics_log, plotting, sink, sinks
from jaxpg.run.rundir import config_io, directory, layout
from jaxpg.run.training import session

ROOT = Path(__file__).resolve().parent.parent
TINY = [
    "--env", "inverted_pendulum", "--num-envs", "8", "--horizon", "32", "--eval-envs", "2",
    "--eval-horizon", "32", "--max-episode-steps", "50", "--checkpoint-every", "2", "--log-every", "2",
    "--no-progress",
]  # fmt: skip
REQUIRED_METRICS = {"iteration", "seed", "env_steps", "wall_time_s", "return_stochastic", "return_mean_policy"}


def without_wall_time(records):
    return [{k: v for k, v in r.items() if k not in ("wall_time_s", "eval_seconds")} for r in records]


EVAL_KEYS = ("evaluated", "return_mean_policy", "episode_length_mean_policy", "task_score_mean_policy")


def same_run(resumed, expected, stopped_at):
    """Bit-identical training metrics and evaluations; the iteration where an earlier process stopped
    also carries that process's final evaluation (every run evaluates its last iteration)."""
    resumed, expected = without_wall_time(resumed), without_wall_time(expected)
    assert len(resumed) == len(expected)
    for got, want in zip(resumed, expected, strict=True):
        if got["iteration"] in stopped_at and not want["evaluated"]:
            assert got["evaluated"] == 1.0 and got["return_mean_policy"] is not None
            got = {k: v for k, v in got.items() if k not in EVAL_KEYS}
            want = {k: v for k, v in want.items() if k not in EVAL_KEYS}
        assert got == want


def listing(path: Path) -> dict:
    return {str(p.relative_to(path)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(path.rglob("*"))}


@pytest.fixture
def gl() -> None:
    """Skip, naming what is missing, where MuJoCo has no OpenGL backend (conftest lets
    ``jaxpg.video.configure_gl`` choose one whose library loads). Where one is found the video tests
    run, so that a broken renderer fails them instead of going unnoticed."""
    from jaxpg import video

    problem = video.gl_problem()
    if problem is not None:
        pytest.skip(f"no video: {problem}")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    return tmp_path_factory.mktemp("runs")


@pytest.fixture(scope="module")
def trained(runs):
    """4 iterations straight, checkpoints at 2 and 4, a video at 4."""
    run_dir = runs / "straight"
    assert main.main([*TINY, "--iterations", "4", "--video-every", "4", "--run-dir", str(run_dir)]) == 0
    return run_dir


# --------------------------------------------------------------------------- run directory


def test_run_directory_holds_everything_to_rerun(trained):
    config = json.loads((trained / "config.json").read_text())
    assert config["task"] == "inverted_pendulum" and config["algo"] == "npg"
    # batch: the most envs stepped together (8 envs x 1 seed), for which the physics is sized
    assert config["env_kwargs"] == {"max_episode_steps": 50, "batch": 8}
    assert config["seeds"] == [0] and config["iterations"] == 4
    from jaxpg.algos import npg

    assert set(config["config"]) == {f.name for f in dataclasses.fields(npg.Config)}
    assert config["config"]["num_envs"] == 8 and config["config"]["policy_hidden"] == [64, 64]
    assert {"jax", "mujoco", "jaxpg", "python"} <= set(config["info"]["versions"])
    assert config["info"]["device"]["backend"] == "cpu"
    # the variables that change how JAX runs, as they were: here the XLA options the tests' conftest sets
    assert config["info"]["environment"]["XLA_FLAGS"] == os.environ["XLA_FLAGS"]
    assert provenance.environment_settings({"XLA_FLAGS": "--x", "HOME": "/h"}) == {"XLA_FLAGS": "--x"}
    run = config_io.RunConfig.load(trained)
    assert run.algo_config() == npg.Config(num_envs=8, horizon=32, eval_envs=2, eval_horizon=32)

    records = metrics_log.read_metrics(trained)
    assert [r["iteration"] for r in records] == [1, 2, 3, 4]
    assert all(REQUIRED_METRICS | {"kl", "value_loss", "episode_length"} <= set(r) for r in records)
    assert records[-1]["env_steps"] == 4 * 8 * 32
    assert all(b["wall_time_s"] >= a["wall_time_s"] for a, b in zip(records, records[1:], strict=False))
    events = list((trained / "tensorboard" / "seed_0").glob("events.out.tfevents.*"))
    assert events and events[0].stat().st_size > 0
    assert (trained / "curves.png").stat().st_size > 0
    assert sorted(p.name for p in (trained / "checkpoints").iterdir()) == ["2", "4"]


def test_training_writes_the_requested_video(gl, trained):
    assert sorted(p.name for p in (trained / "videos").iterdir()) == ["iter_000004.mp4"]
    assert (trained / "videos" / "iter_000004.mp4").stat().st_size > 0


def test_existing_run_directory_is_never_overwritten(trained, capsys):
    before = listing(trained)
    assert main.main([*TINY, "--run-dir", str(trained)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and "--overwrite" in err
    assert listing(trained) == before


def test_overwrite_replaces_only_a_run_directory(trained, runs, capsys):
    copy = runs / "overwritten"
    shutil.copytree(trained, copy)
    assert main.main([*TINY, "--run-dir", str(copy), "--overwrite", "--iterations", "2"]) == 0
    assert [r["iteration"] for r in metrics_log.read_metrics(copy)] == [1, 2]
    assert json.loads((copy / "config.json").read_text())["iterations"] == 2
    foreign = runs / "foreign"
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("precious")
    capsys.readouterr()
    assert main.main([*TINY, "--run-dir", str(foreign), "--overwrite"]) == 2
    assert "not a jaxpg run directory" in capsys.readouterr().err
    assert (foreign / "thesis.tex").read_text() == "precious"


class BlockFiles(sink.Sink):
    """A toy sink: each block's records as one JSON file ``blocks/block_<first>.json``."""

    entries = (sink.Entry("blocks", directory=True, inside=(r"blocks/block_\d+\.json",)),)

    def __init__(self, run_dir: Path):
        self.dir = run_dir / "blocks"
        self.dir.mkdir(exist_ok=True)

    @classmethod
    def open(cls, plan, printer):
        return cls(plan.run_dir)

    def write_block(self, block: sink.Block) -> None:
        (self.dir / f"block_{block.first}.json").write_text(json.dumps(block.records))


def test_a_registered_sink_gets_every_block_and_overwrite_accepts_its_files(runs):
    """A sink added in one place (``sinks.register``) receives every block's records, the same
    ``metrics.jsonl`` holds; the run directory with its files is a jaxpg run that ``--overwrite``
    replaces, and without the sink registered those files are foreign."""
    run_dir = runs / "toy_sink"
    sinks.register(BlockFiles)
    try:
        assert main.main([*TINY, "--iterations", "2", "--run-dir", str(run_dir)]) == 0
        written = [r for f in sorted((run_dir / "blocks").iterdir()) for r in json.loads(f.read_text())]
        assert written and written == metrics_log.read_metrics(run_dir)
        assert directory.foreign_entries(run_dir) == []
        assert main.main([*TINY, "--iterations", "2", "--run-dir", str(run_dir), "--overwrite"]) == 0
        assert [r["iteration"] for r in metrics_log.read_metrics(run_dir)] == [1, 2]
    finally:
        sinks.unregister(BlockFiles)
    assert directory.foreign_entries(run_dir) == ["blocks"]
    with pytest.raises(layout.RunDirError, match="blocks"):
        directory.check_replaceable(run_dir)


# --------------------------------------------------------------------------- resume


def test_resume_is_bit_identical_to_an_uninterrupted_run(trained, runs):
    expected = without_wall_time(metrics_log.read_metrics(trained))
    # 2 iterations, then resumed to a total of 4.
    split = runs / "split"
    assert main.main([*TINY, "--iterations", "2", "--run-dir", str(split)]) == 0
    assert main.main(["--resume", str(split), "--iterations", "4"]) == 0
    same_run(metrics_log.read_metrics(split), metrics_log.read_metrics(trained), stopped_at={2})
    assert json.loads((split / "config.json").read_text())["iterations"] == 4

    # Killed while writing the checkpoint of iteration 4: metrics of iterations 3-4 were logged,
    # the checkpoint is an unfinished temporary directory. Resume redoes 3-4 from checkpoint 2.
    killed = runs / "killed"
    shutil.copytree(trained, killed)
    shutil.move(killed / "checkpoints" / "4", killed / "checkpoints" / "4.orbax-checkpoint-tmp-1763800000000000")
    with (killed / "metrics.jsonl").open("a") as f:
        f.write('{"iteration": 5, "seed": 0, "env_st')  # a torn line
    assert main.main(["--resume", str(killed)]) == 0
    assert without_wall_time(metrics_log.read_metrics(killed)) == expected


def test_minutes_stop_after_the_time_limit_with_a_checkpoint(trained, runs, capsys):
    """``--minutes``: the clock starts after the first block (which compiles); the run stops at
    the first block end past the limit, status 0, with a checkpoint that ``--resume`` continues."""
    limited = runs / "limited"
    assert main.main([*TINY, "--iterations", "8", "--minutes", "1e-9", "--run-dir", str(limited)]) == 0
    assert "time limit of 1e-09 min reached after iteration 4" in capsys.readouterr().out
    records = metrics_log.read_metrics(limited)
    assert [r["iteration"] for r in records] == [1, 2, 3, 4]
    keys = ("iteration", "env_steps", "return_stochastic", "loss")
    assert [[r.get(k) for k in keys] for r in records] == [
        [r.get(k) for k in keys] for r in metrics_log.read_metrics(trained)
    ]
    assert max(int(c.name) for c in (limited / "checkpoints").iterdir() if c.name.isdigit()) == 4
    assert main.main(["--resume", str(limited), "--iterations", "6"]) == 0
    assert metrics_log.read_metrics(limited)[-1]["iteration"] == 6


def test_minutes_bound_the_eta(runs, capsys):
    """With ``--minutes`` the progress line's time left is the time limit's remainder when that
    comes before the last iteration (here 10^6 iterations, about an hour at this rate, against a
    limit of 0.01 s)."""
    run_dir = runs / "eta_limited"
    assert main.main([*TINY, "--iterations", "1000000", "--minutes", "2e-4", "--run-dir", str(run_dir)]) == 0
    out = capsys.readouterr().out
    etas = re.findall(r"ETA (\S+)", out)
    assert etas and all(eta == "0:00" for eta in etas), out


def test_run_saved_under_old_field_names_loads_evaluates_and_resumes(trained, runs, capsys):
    """A run directory written before NPG's ``step_size`` became ``kl_delta``, ``policy_init``
    became ``network_init`` and the metrics ``eval_metric``/``step_size`` became
    ``task_score``/``step_length`` loads with the same Config, its policy acts as before,
    ``jaxpg.evaluate`` runs it, and ``--resume`` continues it and saves its config and metrics
    under the current names."""
    old = runs / "old_names"
    shutil.copytree(trained, old)
    data = json.loads((old / "config.json").read_text())
    saved = data["config"]
    saved["step_size"] = saved.pop("kl_delta")
    saved["policy_init"] = saved.pop("network_init")
    (old / "config.json").write_text(json.dumps(data))
    renamed = {
        "task_score": "eval_metric",
        "task_score_mean_policy": "eval_metric_mean_policy",
        "step_length": "step_size",
    }
    lines = [json.dumps({renamed.get(k, k): v for k, v in r.items()}) for r in metrics_log.read_metrics(trained)]
    (old / "metrics.jsonl").write_text("\n".join(lines) + "\n")
    assert metrics_log.read_metrics(old) == metrics_log.read_metrics(trained)

    assert config_io.RunConfig.load(old).algo_config() == config_io.RunConfig.load(trained).algo_config()
    obs = np.random.default_rng(1).normal(size=(3, 4)).astype(np.float32)
    np.testing.assert_array_equal(jaxpg.load_policy(old)(obs), jaxpg.load_policy(trained)(obs))
    assert evaluate_cli.main([str(old), "--episodes", "1"]) == 0
    assert "return:" in capsys.readouterr().out
    assert main.main(["--resume", str(old), "--iterations", "6"]) == 0
    resaved = json.loads((old / "config.json").read_text())["config"]
    assert resaved["kl_delta"] == saved["step_size"] and resaved["network_init"] == saved["policy_init"]
    assert "step_size" not in resaved and "policy_init" not in resaved
    assert max(r["iteration"] for r in metrics_log.read_metrics(old)) == 6
    written = [json.loads(line) for line in (old / "metrics.jsonl").read_text().splitlines()]
    assert all("task_score" in r and "step_length" in r and not set(renamed.values()) & set(r) for r in written)


def test_old_field_names_map_to_current_ones():
    """TRPO's configs held NPG's ``step_size`` (never used, now gone) and every config a
    ``loop_unroll`` (it changed no number): dropped on load; NPG's ``step_size`` becomes
    ``kl_delta``; a current name already present wins."""
    from jaxpg.algos import npg, ppo, trpo

    assert config_io.config_from_dict(trpo.Config, {"step_size": 0.05, "max_kl": 0.02}) == trpo.Config(max_kl=0.02)
    assert config_io.config_from_dict(npg.Config, {"step_size": 0.2, "policy_init": "pytorch"}) == npg.Config(
        kl_delta=0.2, network_init="pytorch"
    )
    assert config_io.current_field_names(npg.Config, {"step_size": 0.2, "kl_delta": 0.3}) == {"kl_delta": 0.3}
    for module in (npg, ppo, trpo):
        assert config_io.config_from_dict(module.Config, {"loop_unroll": 16}) == module.Config()
    with pytest.raises(layout.RunDirError, match="does not know: step_size"):  # PPO never had one
        config_io.config_from_dict(ppo.Config, {"step_size": 0.2})


def test_resume_of_missing_or_foreign_directory_or_changed_settings(trained, runs, capsys):
    foreign = runs / "not_a_run"
    foreign.mkdir(exist_ok=True)
    (foreign / "notes.txt").write_text("x")
    no_ckpt = runs / "no_checkpoint"
    shutil.copytree(trained, no_ckpt)
    shutil.rmtree(no_ckpt / "checkpoints")
    cases = [
        (["--resume", str(runs / "missing")], "does not exist"),
        (["--resume", str(foreign)], "not a jaxpg run directory"),
        (["--resume", str(no_ckpt)], "no checkpoints"),
        (["--resume", str(trained), "--num-envs", "16"], "drop --num-envs"),
        (["--resume", str(trained), "--seed", "3"], "drop --seed"),
    ]
    for argv, message in cases:
        before = listing(runs)
        assert main.main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("error: ") and message in err, (argv, err)
        assert listing(runs) == before


def test_resume_with_incompatible_checkpoint(trained, runs, capsys):
    other = runs / "other_network"
    shutil.copytree(trained, other)
    config = json.loads((other / "config.json").read_text())
    config["config"]["policy_hidden"] = [32, 32]
    (other / "config.json").write_text(json.dumps(config))
    before = listing(other)
    assert main.main(["--resume", str(other)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not fit this run" in err and "params" in err
    assert listing(other) == before


# --------------------------------------------------------------------------- how a command flows


def driver_calls(argv: list[str]) -> tuple[int, list[str]]:
    """Run the command ``argv``; returns its exit status and, in order, every call that the
    command's driver (the code of ``jaxpg/run/command/main.py``) makes into a function of another jaxpg
    module, as ``module.function``. Between two such calls control has come back up to the
    driver: a command climbs back up ``len(calls) - 1`` times."""
    driver, package = main.__file__, str(Path(jaxpg.__file__).parent)
    calls = []

    def record(frame, event, arg):
        caller = frame.f_back
        if event == "call" and caller is not None and caller.f_code.co_filename == driver:
            callee = frame.f_code.co_filename
            if callee != driver and callee.startswith(package):
                calls.append(f"{frame.f_globals['__name__']}.{frame.f_code.co_name}")

    before = sys.getprofile()
    sys.setprofile(record)
    try:
        status = main.main(argv)
    finally:
        sys.setprofile(before)
    return status, calls


def test_a_run_climbs_back_up_to_its_driver_at_most_twice(trained, runs):
    """``main`` goes down into the host side to start the process, to plan and to execute the
    plan, and control comes back up to it at most twice (it came back ten times when ``main``
    itself parsed flags three times, joined the processes and recovered the run directory)."""
    status, calls = driver_calls([*TINY, "--iterations", "2", "--run-dir", str(runs / "traced")])
    assert status == 0
    assert len(calls) - 1 <= 2, calls
    assert calls[-1] == "jaxpg.run.training.session.execute"


# --------------------------------------------------------------------------- bad input


BAD_INPUT = [
    (["--env", "nope"], "unknown task 'nope'"),
    (["--algo", "nope"], "unknown algorithm 'nope'"),
    (["--num-envs", "0"], "num_envs must be >= 1"),
    (["--num-envs", "-4"], "num_envs must be >= 1"),
    (["--horizon", "2"], "value_batch_size 64 exceeds the 16 samples"),
    (["--preset", "nope"], "unknown preset 'nope'"),
    # Presets are checked against their task: NPG's hopper preset on inverted_pendulum.
    (
        ["--preset", "hopper"],
        "npg's preset 'hopper' was made for hopper, not inverted_pendulum; presets of npg for "
        "inverted_pendulum: lyceum, pendulum_cpu",
    ),
    (["--seeds", "1", "1"], "distinct"),
    (["--iterations", "-1"], "--iterations"),
    (["--policy-hidden", "a"], "--policy-hidden"),
    (["--fidelity", "exact"], "--fidelity"),
    (["--minutes", "0"], "--minutes must be > 0"),
    (["--video-every"], "argument --video-every: expected one argument"),
    (["--env-kwargs", "noise"], "argument --env-kwargs: expected KEY=VALUE, got 'noise'"),
    (
        ["--env-kwargs", "nope=1"],
        "--env-kwargs: task 'inverted_pendulum' has no option 'nope'; its options: max_angle, reset_noise_scale",
    ),
    (["--env-kwargs", "max_angle=wide"], "--env-kwargs: task option max_angle must be a number, got 'wide'"),
    (["--env-kwargs", "impl=jax"], "--env-kwargs: impl is set by its own flag, not --env-kwargs: use --impl"),
    (["--env-kwargs", "max_angle=1", "max_angle=2"], "--env-kwargs gives max_angle more than once"),
]


@pytest.mark.parametrize("extra,message", BAD_INPUT, ids=[" ".join(a) for a, _ in BAD_INPUT])
def test_bad_input_is_one_error_line_with_status_2(extra, message, runs, capsys, monkeypatch):
    monkeypatch.chdir(runs)
    before = listing(runs)
    argv = ["--env", "inverted_pendulum", "--num-envs", "8", *extra, "--run-dir", str(runs / "bad")]
    assert main.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and message in err, err
    assert "Traceback" not in err
    assert listing(runs) == before


def test_num_envs_not_divisible_by_devices_in_a_subprocess(runs):
    """Also checks the ``python -m jaxpg.cli`` entry; two fake CPU devices shard the env batch."""
    env = {
        **os.environ,
        "XLA_FLAGS": f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count=2",
        "JAX_PLATFORMS": "cpu",
    }
    argv = [sys.executable, "-m", "jaxpg.cli", "--env", "inverted_pendulum", "--num-envs", "3"]
    proc = subprocess.run([*argv, "--run-dir", str(runs / "sharded")], capture_output=True, text=True, env=env)
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        "error: --num-envs 3 is not divisible by the 2 devices the env batch is sharded over "
        "(use a multiple, or --no-shard)"
    )
    assert not (runs / "sharded").exists()


def test_help_lists_config_flags_and_gpu_command():
    proc = subprocess.run(
        [sys.executable, str(ROOT / "experiments" / "hopper.py"), "--help"], capture_output=True, text=True
    )
    assert proc.returncode == 0
    for flag in ("--num-envs", "--policy-hidden", "--normalize-observations", "--no-normalize-observations",
                 "--kl-delta", "--seeds", "--resume", "--preset", "--profile", "--video-every"):  # fmt: skip
        assert flag in proc.stdout, flag
    assert "--preset lyceum --seeds 1 2 3 5 8" in proc.stdout


def test_config_flags_parse_into_config(runs, monkeypatch):
    monkeypatch.chdir(runs)
    plan = planning.plan(
        ["--env", "inverted_pendulum", "--policy-hidden", "16", "--normalize-observations", "--gamma", "0.9",
         "--preset", "lyceum", "--seeds", "1", "2", "3", "--run-dir", "planned"],
        command_line.Experiment(),
    )  # fmt: skip
    config = plan.config
    assert config.policy_hidden == (16,) and config.normalize_observations and config.gamma == 0.9
    assert config.value_hidden == (128, 128) and config.sampling == "episodic"  # from the preset
    assert plan.run.seeds == [1, 2, 3] and plan.run.vmap_seeds
    assert not (runs / "planned").exists()
    experiment = command_line.Experiment(config={"*": {"horizon": 16, "no_such_field": 1}, "npg": {"kl_delta": 0.1}})
    plan = planning.plan(["--run-dir", "planned"], experiment)
    assert plan.config.horizon == 16 and plan.config.kl_delta == 0.1


def test_env_kwargs_reach_the_task_the_run_and_gymnasium(runs, tmp_path, monkeypatch):
    """``--env-kwargs`` (and a preset's task options, below it) go to the task, are saved with the
    run (a list comes back as the tuple the task takes) and are given to Gymnasium's env by the
    replay; an option Gymnasium's env lacks is refused there rather than dropped."""
    pytest.importorskip("gymnasium")
    from jaxpg.run.evaluation import replay

    monkeypatch.chdir(runs)
    experiment = command_line.Experiment()
    base = ["--env", "ant", "--impl", "jax", "--run-dir", "planned"]
    plans = {
        "flag": planning.plan([*base, "--env-kwargs", "include_cfrc_ext_in_observation=false"], experiment),
        "preset": planning.plan([*base, "--algo", "ppo", "--preset", "ant_1m"], experiment),
        "flag over preset": planning.plan(
            [*base, "--algo", "ppo", "--preset", "ant_1m", "--env-kwargs", "include_cfrc_ext_in_observation=1"],
            experiment,
        ),
    }
    for name, size in (("flag", 27), ("preset", 27), ("flag over preset", 105)):
        plan = plans[name]
        assert plan.env.observation_size == size, name
        assert plan.run.env_kwargs["include_cfrc_ext_in_observation"] is (size == 105), name
        gym_env = replay.gymnasium_reference_env("ant", plan.run.env_kwargs)
        assert gym_env.observation_space.shape == (size,), name
    assert not (runs / "planned").exists()

    # Ant's A2C preset trains in Gymnasium's physics; --fidelity, given, wins; the replay's own
    # env is Gymnasium's whatever the run's fidelity.
    a2c = ["--algo", "a2c", "--preset", "ant_1m"]
    a2c_plans = {}
    for extra, fidelity, integrator in (([], "gymnasium", "RK4"), (["--fidelity", "fast"], "fast", "EULER")):
        plan = a2c_plans[fidelity] = planning.plan([*base, *a2c, *extra], experiment)
        assert plan.run.env_kwargs["fidelity"] == fidelity, extra
        assert plan.env.unwrapped.mj_model.opt.integrator == getattr(mujoco.mjtIntegrator, "mjINT_" + integrator)
        assert plan.env.observation_size == 27, extra
    assert "fidelity" not in plans["preset"].run.env_kwargs
    gym_env = replay.gymnasium_reference_env("ant", a2c_plans["gymnasium"].run.env_kwargs)
    assert gym_env.observation_space.shape == (27,)

    run = dataclasses.replace(plans["flag"].run, env_kwargs={"healthy_z_range": (0.3, 1.0), "impl": "jax"})
    run.save(tmp_path)
    assert config_io.RunConfig.load(tmp_path).env_kwargs == {"healthy_z_range": (0.3, 1.0), "impl": "jax"}
    with pytest.raises(ValueError, match="Gymnasium's InvertedPendulum-v5 has no option max_angle"):
        replay.gymnasium_reference_env("inverted_pendulum", {"max_angle": 0.3, "impl": "jax"})


# Task options with no keyword of that name in the task's Gymnasium env: the Gymnasium replay refuses a
# run that set one. Every other option of every task with a Gymnasium counterpart is Gymnasium's own.
OPTIONS_GYMNASIUM_LACKS = {
    "inverted_pendulum": ["max_angle"],
    "inverted_double_pendulum": ["min_tip_height"],
    "reacher": ["arm_noise_scale", "arm_velocity_noise_scale", "target_radius"],
    "cartpole": ["reset_bound"],
}


def test_task_options_are_gymnasiums_keywords_but_the_listed_ones():
    """Every task option but the listed ones is a keyword of the task's Gymnasium env, with
    Gymnasium's default."""
    gym = pytest.importorskip("gymnasium")
    import inspect

    from jaxpg import envs
    from jaxpg.run.command import task_options
    from jaxpg.run.evaluation import replay

    lacking = {}
    for task, (gym_id, _) in envs.GYMNASIUM_COUNTERPARTS.items():
        options = task_options.option_types(task)
        assert not set(options) & {"naconmax", "njmax", "fidelity", "impl", "batch"}, task
        try:
            replay.gymnasium_options(task, gym_id, dict.fromkeys(options, 0))
        except ValueError as e:
            lacking[task] = str(e).split(" has no option ")[1].split(", which")[0].split(", ")
        spec = gym.spec(gym_id)
        gym_params = replay.gymnasium_parameters(gym_id)
        ours = inspect.signature(envs.task_class(task)).parameters
        for name in set(options) & set(gym_params):
            theirs = spec.kwargs.get(name, gym_params[name].default)
            np.testing.assert_allclose(np.asarray(ours[name].default, float), np.asarray(theirs, float), err_msg=name)
    assert lacking == OPTIONS_GYMNASIUM_LACKS


def test_a_preset_sets_its_iterations_unless_the_flag_does(runs, monkeypatch):
    """A preset made for a step budget (``hopper_1m``: 120 iterations of 8192 samples) runs that many
    iterations from the command line without ``--iterations``; the flag still wins, and a preset
    without its own count leaves the command's default."""
    monkeypatch.chdir(runs)
    experiment = command_line.Experiment()
    assert experiment.iterations != 120
    base = ["--env", "hopper", "--impl", "jax", "--run-dir", "planned"]
    assert planning.plan([*base, "--preset", "hopper_1m"], experiment).run.iterations == 120
    assert planning.plan([*base, "--preset", "hopper_1m", "--iterations", "7"], experiment).run.iterations == 7
    assert planning.plan([*base, "--preset", "hopper"], experiment).run.iterations == experiment.iterations
    assert not (runs / "planned").exists()


def test_an_experiment_scripts_default_preset_is_replaced_by_a_given_one(runs, monkeypatch):
    """``Experiment.default_presets``: the card's script trains NPG's ``hopper_1m`` without
    ``--preset`` (saved as given, and exactly that preset's values); ``--preset hopper`` gives
    ``hopper``'s values with none of ``hopper_1m``'s left over; another algorithm takes none."""
    from jaxpg import algos
    from jaxpg.algos import npg

    monkeypatch.chdir(runs)
    experiment = load_script("experiments/hopper.py").EXPERIMENT
    base = ["--impl", "jax", "--run-dir", "planned"]
    default = planning.plan(base, experiment)
    assert (default.run.preset, default.run.iterations) == ("hopper_1m", 120)
    assert default.config == npg.Config(**algos.preset("npg", "hopper_1m"))
    assert default.config.eval_action == "clipped_mean" and default.config.log_std_min == 1.0
    hopper = planning.plan([*base, "--preset", "hopper"], experiment)
    assert hopper.run.preset == "hopper" and hopper.config == npg.Config(**algos.preset("npg", "hopper"))
    assert planning.plan([*base, "--algo", "ppo"], experiment).run.preset is None
    # A flag that the default preset's settings refuse: the error names what the preset set.
    with pytest.raises(ValueError, match=r"log_std_final \(1.0\) must be <= log_std_init \(0.0\): the ceiling only "
                       r"falls \(--preset hopper_1m sets --log-std-final 1.0\)$"):  # fmt: skip
        planning.plan([*base, "--log-std-init", "0"], experiment)
    help_text = command_line.build_parser(experiment, "npg", None, {}).format_help()
    assert "(default: hopper_1m)" in " ".join(help_text.split())
    assert not (runs / "planned").exists()


def test_profile(runs, capsys):
    from jaxpg.algos import ppo
    from jaxpg.run.host import profiling

    run = config_io.RunConfig("t", "ppo", {}, [0], 1)
    plan = Plan(run=run, run_dir=runs, module=ppo, env=None, config=None)
    lines = []
    assert session.run_profile(plan, None, lines.append) is None
    assert "profiling isn't available for ppo" in lines[0]
    assert {"npg", "trpo"} <= set(profiling.phased_algorithms()) and "ppo" not in profiling.phased_algorithms()


# --------------------------------------------------------------------------- policies, evaluation, videos


def test_load_policy(trained):
    policy = jaxpg.load_policy(trained)
    assert policy.step == 4 and policy.observation_size == 4 and policy.action_size == 1
    obs = np.random.default_rng(0).normal(size=(5, 4)).astype(np.float32)
    actions = policy(obs)
    assert isinstance(actions, np.ndarray) and actions.shape == (5, 1)
    # One observation is another program than five (a matrix-vector product instead of a matrix
    # product), with another float32 summation order: equal to a few ulps, measured up to 10.
    np.testing.assert_allclose(policy(obs[2]), actions[2], rtol=1e-5)
    np.testing.assert_array_equal(policy(obs), actions)  # deterministic
    # The mode of the checkpointed policy, normalisation and clipping applied.
    ts, step = policy_io.restore_train_state(trained)
    expected = ts.policy.mode(ts.params, ts.obs_stats.normalize(obs))
    np.testing.assert_allclose(actions, np.clip(expected, policy.action_low, policy.action_high), rtol=1e-6)
    assert jaxpg.load_policy(trained, 2).step == 2
    stochastic = jaxpg.load_policy(trained, deterministic=False)
    # Near the upright state (where the pendulum's observations live) the samples are not all
    # clipped to the action bounds, so two draws differ.
    near = obs * 0.01
    assert not np.array_equal(stochastic(near), stochastic(near))
    with pytest.raises(ValueError, match="expected an observation"):
        policy(np.zeros(3))
    with pytest.raises(ValueError, match="no checkpoint of step 3"):
        jaxpg.load_policy(trained, 3)


def test_evaluate_in_jaxpg_and_gymnasium(trained, tmp_path, capsys):
    assert evaluate_cli.main([str(trained), "--episodes", "1"]) == 0
    out = capsys.readouterr().out
    assert "jaxpg inverted_pendulum" in out and "return:" in out and "length:" in out
    assert evaluate_cli.main([str(trained), "--episodes", "2", "--gymnasium"]) == 0
    out = capsys.readouterr().out
    assert "Gymnasium InvertedPendulum-v5" in out and "return:" in out
    assert evaluate_cli.main([str(tmp_path / "missing"), "--episodes", "1"]) == 2
    assert capsys.readouterr().err.startswith("error: run directory")
    # A run given an option that Gymnasium's env lacks is not replayed there as another task.
    copy = tmp_path / "with_option"
    shutil.copytree(trained, copy)
    config = json.loads((copy / "config.json").read_text())
    config["env_kwargs"]["max_angle"] = 0.2  # the default: the run itself is unchanged
    (copy / "config.json").write_text(json.dumps(config))
    assert evaluate_cli.main([str(copy), "--episodes", "1"]) == 0
    capsys.readouterr()
    assert evaluate_cli.main([str(copy), "--episodes", "1", "--gymnasium"]) == 2
    assert capsys.readouterr().err == (
        "error: --gymnasium: Gymnasium's InvertedPendulum-v5 has no option max_angle, which this run's env was given\n"
    )


@pytest.mark.parametrize("gymnasium", [False, True], ids=["jaxpg", "gymnasium"])
def test_evaluate_writes_a_video(gl, trained, tmp_path, capsys, gymnasium):
    video = tmp_path / "episode.gif"
    argv = [str(trained), "--episodes", "1", "--video", str(video)] + (["--gymnasium"] if gymnasium else [])
    assert evaluate_cli.main(argv) == 0, capsys.readouterr().err
    assert f"video of episode 1: {video}" in capsys.readouterr().out
    frames = imageio.mimread(video)
    assert len(frames) > 1 and max(int(f.max()) for f in frames) > 0


def test_evaluate_chooses_a_gl_backend_only_for_a_video(monkeypatch, tmp_path, capsys):
    """``jaxpg.evaluate`` leaves ``MUJOCO_GL`` to ``jaxpg.video.configure_gl`` (a backend whose
    library loads) and asks for one only when ``--video`` is given."""
    from jaxpg import video

    calls = []
    monkeypatch.setattr(video, "configure_gl", lambda: calls.append("configure_gl"))
    missing = str(tmp_path / "missing")
    assert evaluate_cli.main([missing, "--episodes", "1"]) == 2
    assert calls == []
    assert evaluate_cli.main([missing, "--episodes", "1", "--video", str(tmp_path / "v.gif")]) == 2
    assert calls == ["configure_gl"]
    capsys.readouterr()


def test_video_of_cartpole_is_drawn_without_mujoco(tmp_path):
    from jaxpg import envs, video

    env = envs.make_shared("cartpole")
    obs = np.array([[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.2, 0.0]], np.float32)
    frames = video.render_states(env, obs, None, None)
    assert frames[0].shape == (400, 640, 3) and frames[0].dtype == np.uint8
    assert not np.array_equal(frames[0], frames[1])
    path = video.write_video(frames, tmp_path / "cartpole.gif", fps=50)
    assert path.stat().st_size > 0


# --------------------------------------------------------------------------- host-side pieces


def test_several_seeds_records_summary_and_curves(tmp_path):
    metrics = {
        "env_steps": np.array([[256.0, 256.0], [512.0, 512.0]]),
        "return_stochastic": np.array([[1.0, 3.0], [np.nan, 5.0]]),
        "return_mean_policy": np.array([[2.0, 4.0], [6.0, 8.0]]),
        "kl": np.array([[0.01, 0.02], [0.03, 0.04]], np.float32),
    }
    records = metrics_log.block_records(metrics, 4, [1, 2], [1.0, 2.0])
    assert [(r["iteration"], r["seed"]) for r in records] == [(5, 1), (5, 2), (6, 1), (6, 2)]
    assert records[2]["return_stochastic"] is None and records[3]["return_stochastic"] == 5.0
    assert records[0]["kl"] == float(np.float32(0.01))  # float32 values survive JSON exactly
    line = console.summary_line(metrics, 6, 10, 12345.0)
    assert line.startswith("[ 6/10]") and "12.3k steps/s" in line and "mean policy 5.0±" in line
    assert metrics_log.latest_score(metrics) == 7.0
    iterations, values = plotting.seed_curves(records, "return_mean_policy")
    assert iterations.tolist() == [5, 6] and values.tolist() == [[2.0, 4.0], [6.0, 8.0]]
    out = plotting.plot_runs([("run", records)], tmp_path / "curves.png", title="t", task_score_name="return")
    assert out.stat().st_size > 0


def test_the_line_about_rolled_back_updates_names_their_cause():
    """``console.rejection_line``: nothing when no update was rolled back; else the count, and the
    cause: the largest mean KL of a rolled-back update (over seeds too), non-finite values; a run
    with normalised observations whose only rolled-back update is iteration 1's gets a note."""

    def block(rejected, kl, failures):
        return {
            "update_rejected": np.array(rejected, np.float32),
            "kl": np.array(kl, np.float32),
            "consecutive_failures": np.array(failures, np.float32),
        }

    assert console.rejection_line(block([0, 0], [0.01, 0.02], [0, 0]), 0, 1.0, True) is None
    first = block([1, 0, 0], [67.7, 0.01, 0.01], [0, 0, 0])
    note = console.rejection_line(first, 0, 1.0, True)
    assert note.startswith("note: iteration 1's update was rolled back (largest mean KL 67.7, above max_update_kl 1)")
    warning = console.rejection_line(first, 0, 1.0, False)
    assert warning == (
        "warning: 1 of iterations 1-3 were rolled back (largest mean KL 67.7, above max_update_kl 1); "
        "lower the step size or learning rate"
    )
    seeds = block([[0, 1], [1, 0]], [[0.5, 3.0], [2.5, 0.9]], [[0, 0], [1, 0]])  # [iterations, seeds]
    assert console.rejection_line(seeds, 20, 1.0, True) == (
        "warning: 2 of iterations 21-22 were rolled back (largest mean KL 3.0, above max_update_kl 1; "
        "1 with non-finite values); lower the step size or learning rate"
    )
    nonfinite = block([1], [float("nan")], [1])
    assert "(1 with non-finite values)" in console.rejection_line(nonfinite, 0, 1.0, True)
    no_step = block([0, 1], [0.01, 0.0], [0, 0])  # NPG's backtracking found no step within its bound
    assert "(1 with no step the algorithm accepted)" in console.rejection_line(no_step, 0, 1.0, True)


def test_every_algorithm_config_round_trips_through_json():
    from jaxpg import algos

    for name in algos.ALGORITHMS:  # every algorithm module ships with the package: a missing one fails here
        module = algos.get(name)
        config = module.Config()
        for preset in getattr(module, "PRESETS", {}).values():
            config = module.Config(**preset)
            data = json.loads(json.dumps(config_io.config_to_dict(config)))
            assert config_io.config_from_dict(module.Config, data) == config
        with pytest.raises(layout.RunDirError, match="does not know: bogus"):
            config_io.config_from_dict(module.Config, {"bogus": 1})


def test_every_hyperparameter_flag_says_what_it_is():
    """Each Config field of each algorithm has a one-line meaning, and fixed string fields list
    their values in ``--help``."""
    import dataclasses

    from jaxpg import algos
    from jaxpg.algos.field_help import FIELD_HELP, field_choices

    for name in algos.ALGORITHMS:
        config_cls = algos.get(name).Config
        missing = [f.name for f in dataclasses.fields(config_cls) if f.name not in FIELD_HELP]
        assert not missing, (name, missing)
    assert field_choices(algos.get("a2c").Config, "optimizer") == ("rmsprop", "adam")
    assert field_choices(algos.get("vpg").Config, "optimizer") == ("adam", "adamw")
    parser = command_line.build_parser(
        command_line.Experiment(task="inverted_pendulum"), "npg", algos.get("npg").Config, {}
    )
    text = parser.format_help()
    assert "Fisher-vector product" in text and "{gauss_newton,kl_hessian}" in text


def test_gl_backend_is_chosen_only_when_videos_may_be_drawn():
    """``startup.start`` leaves ``MUJOCO_GL`` alone unless the command may draw a video."""
    experiment = command_line.Experiment(task="inverted_pendulum")

    def videos(argv, experiment=experiment):
        return pre_flags.parse_pre_flags(argv, experiment).videos

    assert not videos(["--iterations", "3"])
    assert not videos(["--video-every", "0"])
    assert videos(["--video-every", "2"])
    assert videos(["--video-every=5"])
    assert videos(["--resume", "runs/x"])
    assert videos([], command_line.Experiment(task="inverted_pendulum", video_every=10))
    assert not videos(["--video-every", "many"])  # the full parse reports it
    assert videos(["--video", "5"])  # an abbreviation argparse accepts


def test_pre_flags_are_read_in_one_pass_as_the_full_parser_reads_them():
    """The flags needed before the full parse, read once (abbreviations included); the others are
    left to the full parse, which reads the same values."""
    argv = ["--env", "hopper", "--algo", "ppo", "--num-envs", "8", "--res", "runs/a", "--run-dir", "runs/b",
            "--preset", "lyceum", "--video-every", "0", "--coordinator", "host:1234", "--num-processes", "2",
            "--process-id", "1", "--distributed-timeout", "5"]  # fmt: skip
    pre = pre_flags.parse_pre_flags(argv, command_line.Experiment())
    assert pre == pre_flags.PreFlags(
        algo="ppo", preset="lyceum", resume="runs/a", run_dir="runs/b", videos=True,
        coordinator_address="host:1234", num_processes=2, process_id=1, distributed_timeout=5,
    )  # fmt: skip
    assert pre.target == "runs/a"
    assert pre_flags.parse_pre_flags(["--run-dir", "b"], command_line.Experiment()).target == "b"
    full, _ = command_line.build_parser(command_line.Experiment(), "ppo", None, {}).parse_known_args(argv)
    fields = [f.name for f in dataclasses.fields(pre_flags.PreFlags) if f.name != "videos"]
    assert {name: getattr(full, name) for name in fields} == {name: getattr(pre, name) for name in fields}
    with pytest.raises(UsageError, match="argument --num-processes: invalid int value: 'x'"):
        pre_flags.parse_pre_flags(["--num-processes", "x"], command_line.Experiment())


def test_exit_process_finishes_what_the_interpreter_exit_would(tmp_path):
    """``exit_process`` (the scripts' last line) ends the process with the given status only after
    what a normal exit does first: a thread that is not a daemon finishes its write, the ``atexit``
    handlers run, and output still buffered in ``sys.stdout`` is written."""
    script = f"""
import atexit, pathlib, sys, threading, time
from jaxpg.run.command.main import exit_process
out = pathlib.Path({str(tmp_path)!r})
threading.Thread(target=lambda: (time.sleep(0.5), (out / "thread").write_text("done"))).start()
atexit.register(lambda: (out / "atexit").write_text("ran"))
sys.stdout.write("buffered, no newline")
exit_process(3)
"""
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 3, proc.stderr
    assert proc.stdout == "buffered, no newline"
    assert (tmp_path / "thread").read_text() == "done" and (tmp_path / "atexit").read_text() == "ran"


def test_a_command_that_owns_its_process_takes_gpu_memory_on_demand(tmp_path):
    """``python -m jaxpg.cli``, the experiment scripts and ``python -m jaxpg.evaluate`` (each the
    whole process) set ``XLA_PYTHON_CLIENT_PREALLOCATE=false`` before JAX starts its backend, so
    that JAX does not reserve 75 % of a GPU's memory at its first buffer; a value set by the user
    is kept, and a command called from someone else's program (``owns_process`` False) leaves the
    variable alone. Each command here stops with a usage error after its start."""
    script = f"""
import os
from jaxpg.run.evaluation import evaluate_cli
from jaxpg.run.command import main, startup
VARIABLE, seen = startup.PREALLOCATE_VARIABLE, []
check_backend = startup.check_backend
startup.check_backend = lambda: (seen.append(os.environ.get(VARIABLE)), check_backend())[1]
bogus = ["--env", "inverted_pendulum", "--env-kwargs", "bogus=1"]
os.environ.pop(VARIABLE, None)
print(main.main(bogus), os.environ.get(VARIABLE), seen)
print(main.main(bogus, owns_process=True), os.environ.get(VARIABLE), seen)
os.environ[VARIABLE] = "true"
print(main.main(bogus, owns_process=True), os.environ.get(VARIABLE))
os.environ.pop(VARIABLE)
print(evaluate_cli.main([{str(tmp_path / "no_run")!r}], owns_process=True), os.environ.get(VARIABLE))
"""
    env = {k: v for k, v in os.environ.items() if k != "XLA_PYTHON_CLIENT_PREALLOCATE"}
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.splitlines() == ["2 None [None]", "2 false [None, 'false']", "2 true", "2 false"]
    assert startup_module.allocate_gpu_memory_on_demand({}) == "false"
    assert startup_module.allocate_gpu_memory_on_demand({"XLA_PYTHON_CLIENT_PREALLOCATE": "1"}) == "1"


def test_the_end_report_times_the_first_block(runs, capsys):
    """The report after ``done in`` says how long the first block's program took to compile (here
    with no MuJoCo Warp kernels to wait for, so without that clause)."""
    assert main.main([*TINY, "--iterations", "2", "--run-dir", str(runs / "first_block")]) == 0
    lines = capsys.readouterr().out.splitlines()
    # before the first block, a line says that it compiles (a MuJoCo task on a CPU takes minutes)
    training = next(i for i, line in enumerate(lines) if line.startswith("training: "))
    assert re.fullmatch(
        r"compiling: the first block of 2 iteration\(s\) compiles before its first metrics line \(.*\)",
        lines[training + 1],
    ), lines[training : training + 2]
    done = next(i for i, line in enumerate(lines) if line.startswith("done in "))
    assert re.fullmatch(r"first block: compiled in \d+\.\d s", lines[done + 1]), lines[done + 1]
    # then where the start-up went: pytest's process was not started for this command, so its age
    # is left out; MJX is imported while planning if no earlier test of this process imported it
    startup = r"start-up: (\d+\.\d) s to the first block: (\d+\.\d) s planning and building the env"
    startup += r"(?: \(\d+\.\d s of it importing mujoco\.mjx\))?, "
    startup += r"(\d+\.\d) s the initial state, (\d+\.\d) s the run directory and the rest"
    match = re.fullmatch(startup, lines[done + 2])
    assert match, lines[done + 2]
    total, *parts = map(float, match.groups())
    assert abs(sum(parts) - total) <= 0.2  # each part rounded to 0.1 s


@pytest.mark.parametrize(
    ("main_file", "spec_name", "for_this"),
    [
        ("/home/me/jaxpg/experiments/hopper.py", None, True),  # python experiments/hopper.py
        ("/usr/lib/python3/site-packages/jaxpg/cli.py", "jaxpg.cli", True),  # python -m jaxpg.cli
        ("/home/me/.venv/bin/pytest", None, False),  # an installed tool's launcher
        ("/home/me/.venv/lib/python3.11/site-packages/pytest/__main__.py", "pytest.__main__", False),
        (None, None, False),  # an interactive interpreter or a notebook's kernel
    ],
)
def test_startup_counts_the_process_age_only_for_a_process_started_for_the_command(
    main_file, spec_name, for_this, monkeypatch
):
    """The start-up line's "before planning" part is the process's age, which means something only
    when the process was started for this command; pytest's own launcher is not."""
    import types

    from jaxpg.run.command import startup_times

    entry = types.ModuleType("__main__")
    if main_file is not None:
        entry.__file__ = main_file
    entry.__spec__ = types.SimpleNamespace(name=spec_name) if spec_name else None
    monkeypatch.setitem(sys.modules, "__main__", entry)
    monkeypatch.setattr(startup_times, "seconds_since_process_start", lambda: 12.5)
    monkeypatch.setattr(startup_times, "CHILDREN_CPU_AT_IMPORT", 0.0)  # Python started as the process's first program
    assert (startup_times.StartupTimes.start().before_planning == 12.5) is for_this
    # A shell that ran `pip install` and then exec-ed Python in its own process: its age counts pip.
    monkeypatch.setattr(startup_times, "CHILDREN_CPU_AT_IMPORT", 3.0)
    assert startup_times.StartupTimes.start().before_planning is None


def test_startup_report_splits_the_seconds_to_the_first_block():
    """``StartupTimes.report``: the process's seconds before planning, then planning (with the MJX
    import inside it when it happened there), the initial state and the rest, summing to the total."""
    from jaxpg.run.command import startup_times

    times = startup_times.StartupTimes(before_planning=2.0, planning=100.0, planned=104.0, state_ready=104.5)
    assert times.report(105.5) is not None
    original = startup_times.mjx_import_span
    try:
        startup_times.mjx_import_span = lambda: (100.5, 103.3)
        assert times.report(105.5) == (
            "start-up: 7.5 s to the first block: 2.0 s before planning, 4.0 s planning "
            "and building the env (2.8 s of it importing mujoco.mjx), 0.5 s the initial state, 1.0 s the run "
            "directory and the rest"
        )
        startup_times.mjx_import_span = lambda: (0.5, 1.7)  # imported before main
        assert "2.0 s before planning (1.2 s of it importing mujoco.mjx), 4.0 s planning" in times.report(105.5)
    finally:
        startup_times.mjx_import_span = original
    assert startup_times.StartupTimes(before_planning=None, planning=1.0).report(2.0) is None  # not planned yet
    since = startup_times.seconds_since_process_start()
    assert since is None or 0.0 <= since < 3600.0
