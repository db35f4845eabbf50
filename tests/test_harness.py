"""``benchmarks/harness.py``'s command line for scripts with modes, and the scripts that use it."""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import threading
import time

import pytest
from script_loader import ROOT, load_script


@pytest.fixture(scope="module")
def harness():
    return load_script("benchmarks/harness.py")


def test_run_modes_hands_the_options_to_the_mode(harness):
    calls = []
    modes = {"env": calls.append, "train": lambda options: calls.append(("train", options))}
    harness.run_modes("benchmarks/x.py", modes, "the doc", ["train", "--iterations", "3"])
    assert calls == [("train", ["--iterations", "3"])]


@pytest.mark.parametrize("argv", [[], ["nope"]], ids=["no mode", "unknown mode"])
def test_run_modes_without_a_known_mode_prints_the_doc_and_the_usage(harness, argv, capsys):
    with pytest.raises(SystemExit) as exit_:
        harness.run_modes("/anywhere/x.py", {"env": print, "train": print}, "the doc", argv)
    assert exit_.value.code == "usage: python benchmarks/x.py {env,train} [options]"
    assert capsys.readouterr().out == "the doc\n"


@pytest.mark.parametrize("script", ["throughput", "time_to_return", "card_command", "suite"])
def test_the_scripts_with_modes_name_them_when_run_without_one(script):
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / f"{script}.py")], capture_output=True, text=True, cwd=ROOT
    )
    modes = load_script(f"benchmarks/{script}.py").MODES
    assert proc.returncode == 1
    assert (
        proc.stderr.strip().splitlines()[-1] == f"usage: python benchmarks/{script}.py {{{','.join(modes)}}} [options]"
    )


def test_a_run_is_split_by_the_arrival_of_its_output_lines():
    """card_command.py's split of a run: start-up to the ``training:`` line; the first block to the
    first progress line, less the compilation and the kernel wait that its ``first block:`` line
    reports; the other iterations to ``done in``, less the evaluation its ``evaluation:`` line
    reports; then the exit. A part whose line never came is ``None``."""
    split = load_script("benchmarks/card_command.py").card.split
    lines = [(9.8, "training: npg on hopper"), (10.0, "warning: x"), (34.2, "[ 10/120] | steps"), (36.0, "[ 20/120]")]
    lines += [(60.0, "done in 39.7 s: 0.129 s per iteration, 127,000 env steps/s after compilation")]
    lines += [(60.1, "first block: compiled in 9.5 s, then 2.5 s waiting for MuJoCo Warp's kernels (41 modules built")]
    lines += [
        (60.2, "evaluation: 1 of the mean policy (16 episodes each), 1.3 s (3.3% of the training loop's wall clock)")
    ]
    parts = split(lines, 62.5)
    expected = {"startup": 9.8, "xla_compile": 9.5, "kernel_wait": 2.5, "first_block": 12.4, "training": 24.5}
    assert parts == pytest.approx({**expected, "evaluation": 1.3, "exit": 2.5})
    # a CPU run: no kernels, so no wait in its first-block line
    cpu = split(
        [(1.0, "training: x"), (5.0, "[ 2/2] |"), (6.0, "done in 5.0 s"), (6.1, "first block: compiled in 3.0 s")], 7.0
    )
    assert cpu == pytest.approx(
        {
            "startup": 1.0,
            "xla_compile": 3.0,
            "kernel_wait": 0.0,
            "first_block": 1.0,
            "training": 1.0,
            "evaluation": 0.0,
            "exit": 1.0,
        }
    )
    assert split([(1.0, "error: no such task")], 2.0) == {**dict.fromkeys(parts), "startup": None}


def test_the_startup_line_splits_into_imports_env_state_and_run_dir():
    """card_command.py reads the run's ``start-up:`` line: imports are the seconds before planning
    plus the MJX import inside planning, the env is the rest of planning."""
    parts = load_script("benchmarks/card_command.py").card.startup_parts
    line = (
        "start-up: 7.4 s to the first block: 2.1 s before planning, 4.1 s planning and building the env "
        "(2.8 s of it importing mujoco.mjx), 0.4 s the initial state, 0.8 s the run directory and the rest"
    )
    got = parts([(1.0, "training: x"), (30.0, line)])
    assert got == pytest.approx({"imports": 4.9, "env": 1.3, "initial_state": 0.4, "run_dir": 0.8})
    before = line.replace(
        "before planning, 4.1 s planning and building the env (2.8 s of it importing mujoco.mjx)",
        "before planning (2.8 s of it importing mujoco.mjx), 4.1 s planning and building the env",
    )
    assert parts([(30.0, before)]) == pytest.approx({"imports": 2.1, "env": 4.1, "initial_state": 0.4, "run_dir": 0.8})
    assert parts([(1.0, "training: x")]) is None
    no_age = "start-up: 5.3 s to the first block: 4.1 s planning and building the env, 0.4 s the initial state"
    assert parts([(30.0, no_age)]) is None


def test_a_stack_sample_is_an_import_or_its_innermost_jaxpg_frame():
    """card_command.py startup --sample names each sample of the main thread (innermost frame
    first): an import in progress, else the innermost frame of jaxpg, else the innermost frame."""
    activity = load_script("benchmarks/card_command.py").startup.sampled_activity
    jaxpg_frames = (
        "/x/site-packages/jax/_src/api.py:device_put;/repo/jaxpg/envs/mjx_env.py:__init__;"
        "/repo/jaxpg/run/command/main.py:main"
    )
    assert activity(jaxpg_frames) == "mjx_env.py:__init__"
    assert (
        activity(
            "/x/mjx/io.py:<module>;<frozen importlib._bootstrap>:_find_and_load;/repo/jaxpg/run/command/main.py:main"
        )
        == "import"
    )
    assert activity("/usr/lib/python3.12/threading.py:wait;<string>:<module>") == "threading.py:wait"


def test_suite_judges_each_preset_against_its_target():
    verdicts = load_script("benchmarks/suite.py").verdicts
    assert verdicts.judge("walker2d", "walker2d_1m", [3900.0, 3800.0, 4000.0], [90.0] * 3, [1e6] * 3).startswith("met")
    assert verdicts.judge("walker2d", "walker2d_1m", [3000.0], [90.0], [1e6]).startswith("missed by 827")
    assert "over 1 M steps" in verdicts.judge("hopper", "hopper_1m", [3000.0], [90.0], [2e6])
    assert verdicts.judge("ant", "ant_fast", [4100.0, 4200.0, 3900.0], [200.0] * 3, [5e7] * 3).startswith("met")
    assert "too slow" in verdicts.judge("ant", "ant_fast", [4100.0], [400.0], [5e7])
    assert verdicts.judge("humanoid", "humanoid_fast", [4000.0], [500.0], [5e7]).startswith("missed by 1000")
    assert verdicts.judge("swimmer", "swimmer_fast", [300.0], [60.0], [1e7]).startswith("missed by 65.70")
    assert verdicts.judge("reacher", "reacher_fast", [-2.5, -2.4, -3.0], [60.0] * 3, [1e7] * 3).startswith("met")
    assert verdicts.judge("humanoid_standup", "humanoid_standup_fast", [1e5], [60.0], [1e7]) == "no target"
    assert verdicts.judge("ant", "ant_fast", [], [60.0], [1e7]) == "no score"


def test_suite_prints_returns_under_100_with_two_decimals():
    """Reacher's and Pusher's returns differ in their decimals, the other tasks' in their hundreds."""
    verdicts = load_script("benchmarks/suite.py").verdicts
    assert [verdicts.score_text(x) for x in (3346.4, -150.2, -28.744, -3.4823)] == ["3346", "-150", "-28.74", "-3.48"]


def test_suite_physics_variants_change_only_the_integrator_and_the_solver_iterations():
    """``suite.py physics`` replays a policy in Gymnasium's Hopper-v5 under each variant: the file's
    own physics (RK4, up to 100 and 50 iterations), jaxpg's fast fidelity and the two halves of it."""
    import mujoco

    from jaxpg.envs import mjx_env
    from jaxpg.run.evaluation import replay

    suite = load_script("benchmarks/suite.py")
    settings = {}
    for variant in suite.physics.PHYSICS_VARIANTS:
        env = replay.gymnasium_reference_env("hopper", {})
        suite.physics.set_physics(env.unwrapped.model, variant)
        opt = env.unwrapped.model.opt
        settings[variant] = (suite.physics.mujoco_name(opt.integrator), opt.iterations, opt.ls_iterations, opt.timestep)
        env.close()
    fast = (mjx_env.FAST_SOLVER_ITERATIONS, mjx_env.FAST_LS_ITERATIONS)
    assert settings == {
        "gymnasium": ("RK4", 100, 50, 0.002),
        "fast": ("EULER", *fast, 0.002),
        "euler": ("EULER", 100, 50, 0.002),
        "rk4_fast_solver": ("RK4", *fast, 0.002),
    }
    model = mjx_env.load_model("hopper.xml", "fast").opt  # the same settings as jaxpg's fast Hopper
    assert (model.integrator, model.iterations, model.ls_iterations) == (mujoco.mjtIntegrator.mjINT_EULER, *fast)


def test_suite_names_a_block_of_many_seeds_within_a_file_name():
    suite = load_script("benchmarks/suite.py")
    assert suite.verdicts.seeds_label([3]) == "seed3"
    assert suite.verdicts.seeds_label([0, 2, 5]) == "seed0-2-5"
    assert suite.verdicts.seeds_label([4, 5]) == "seed4-5"
    assert suite.verdicts.seeds_label(list(range(1000, 1064))) == "seeds1000to1063"
    assert suite.verdicts.seeds_label([1, 2, 3, 5]) == "seed1-2-3-5"


def test_suite_counts_each_setting_s_seeds_below_the_bar_once():
    suite = load_script("benchmarks/suite.py")

    def row(seed: int, score: float | None, extra: list[str]) -> dict:
        return {
            "task": "hopper",
            "algo": "npg",
            "preset": "hopper_1m",
            "seed": seed,
            "gymnasium_return": score,
            "extra": extra,
        }

    rows = [
        row(0, 3100.0, []),
        row(1, 2500.0, []),
        row(2, 900.0, []),
        row(1, 2600.0, []),
        row(3, None, []),
        row(0, 2000.0, ["--kl-delta", "0.1"]),
    ]
    base, kl = suite.count.tally(rows, 3000.0)
    assert (base["run"], base["extra"], base["seeds"], base["reached"]) == ("hopper:npg:hopper_1m", "", 3, 1)
    assert base["below"] == [(2, 900.0), (1, 2600.0)]  # seed 1 once, at its later score; seed 3 unscored
    assert (base["lowest"], base["median"]) == (900.0, 2600.0)
    assert (kl["extra"], kl["seeds"], kl["reached"]) == ("--kl-delta 0.1", 1, 0)


def test_suite_runs_one_job_at_a_time_on_each_gpu():
    """``suite.py run --gpus``: every job runs once, on one GPU at a time, the GPUs side by side; a
    failed job is raised after the others ended."""
    on_gpus = load_script("benchmarks/suite.py").run.on_gpus
    busy, seen, overlaps, lock = set(), [], [], threading.Lock()

    def work(job, gpu):
        with lock:
            overlaps.append(gpu in busy)
            busy.add(gpu)
        time.sleep(0.01)
        with lock:
            busy.discard(gpu)
            seen.append((job, gpu))

    on_gpus(range(9), [0, 1, 2], work)
    assert sorted(job for job, _ in seen) == list(range(9)) and not any(overlaps)
    assert {gpu for _, gpu in seen} == {0, 1, 2}

    def fail_on_three(job, gpu):
        seen.append((job, gpu))
        if job == 3:
            raise RuntimeError("job 3")

    seen.clear()
    with pytest.raises(RuntimeError, match="job 3"):
        on_gpus(range(6), [None, None], fail_on_three)
    assert sorted(job for job, _ in seen) == list(range(6))


def test_suite_gpus_take_the_first_ready_job_and_wait_when_none_is():
    """``on_gpus`` with ``ready``: a free GPU skips jobs that are not ready (a warm run whose bare
    run has not ended) for the next that is, and waits while none is, until a job ends."""
    on_gpus = load_script("benchmarks/suite.py").run.on_gpus
    ended, order, lock = set(), [], threading.Lock()

    def work(job, gpu):
        time.sleep(0.05 if job == "a-bare" else 0.01)
        with lock:
            order.append(job)
            ended.add(job)

    jobs = ["a-bare", "a-warm", "b-bare", "b-warm"]
    on_gpus(jobs, [0, 1], work, ready=lambda job: not job.endswith("warm") or job[0] + "-bare" in ended)
    assert order.index("b-bare") < order.index("a-bare") < order.index("a-warm")  # b-bare ran beside a-bare
    assert order.index("b-bare") < order.index("b-warm") and sorted(order) == sorted(jobs)
    order.clear(), ended.clear()
    on_gpus(jobs, [None], work, ready=lambda job: not job.endswith("warm") or job[0] + "-bare" in ended)
    assert order == jobs  # one GPU: preset by preset


def test_suite_bare_first_times_one_bare_run_then_every_seed_with_its_caches(tmp_path, monkeypatch, capsys):
    """``suite.py run --bare-first``: each preset's first seed runs first with empty caches of its
    own (a "bare" row), then every seed runs with the caches that run filled ("warm" rows); the
    table reports the two apart. ``--bare-first`` with ``--cold`` or ``--warmup`` is refused."""
    suite = load_script("benchmarks/suite.py")
    calls = []

    def fake_train(task, algo, preset, seeds, place, caches, extra, gpu=None):
        calls.append((seeds, place.name, caches.name, caches.exists()))
        caches.mkdir(parents=True, exist_ok=True)  # what a run leaves behind
        row = {"task": task, "algo": algo, "preset": preset, "seed": seeds[0], "wall_s": 1.0, "env_steps": 10.0}
        return [{**row, "in_run_mean_policy": 5.0, "status": 0, "run_dir": str(place / "run")}]

    monkeypatch.setattr(suite.run, "train_and_time", fake_train)
    (tmp_path / "caches-hopper-hopper-0").mkdir()  # a stale cache the bare run must not find
    args = ["--runs", "hopper:npg:hopper", "--seeds", "0", "1", "--episodes", "0", "--out", str(tmp_path)]
    suite.run.run_main([*args, "--bare-first", "--json", str(tmp_path / "out.json")])
    assert calls == [
        ([0], "bare", "caches-hopper-hopper-0", False),
        ([0], tmp_path.name, "caches-hopper-hopper-0", True),
        ([1], tmp_path.name, "caches-hopper-hopper-0", True),
    ]
    runs = [group["run"] for group in json.loads((tmp_path / "out.json").read_text())["meta"]["summary"]]
    assert runs == ["hopper:npg:hopper (bare)", "hopper:npg:hopper (warm)"]
    assert "partial" not in json.loads((tmp_path / "out.json").read_text())["meta"]

    # Two presets go preset by preset, and the JSON holds every run that has ended, as it ends.
    calls.clear()
    saved = []

    def fake_train_reading_json(task, algo, preset, seeds, place, caches, extra, gpu=None):
        path = tmp_path / "two.json"
        saved.append(len(json.loads(path.read_text())["rows"]) if path.exists() else 0)
        return fake_train(task, algo, preset, seeds, place, caches, extra, gpu)

    monkeypatch.setattr(suite.run, "train_and_time", fake_train_reading_json)
    two = ["--runs", "hopper:npg:hopper", "walker2d:npg:walker2d_1m", *args[2:]]
    suite.run.run_main([*two, "--bare-first", "--json", str(tmp_path / "two.json")])
    assert [(seeds, caches) for seeds, _, caches, _ in calls] == [
        ([0], "caches-hopper-hopper-0"),
        ([0], "caches-hopper-hopper-0"),
        ([1], "caches-hopper-hopper-0"),
        ([0], "caches-walker2d-walker2d_1m-0"),
        ([0], "caches-walker2d-walker2d_1m-0"),
        ([1], "caches-walker2d-walker2d_1m-0"),
    ]
    assert saved == [0, 1, 2, 3, 4, 5]
    for other in ("--cold", "--warmup"):
        with pytest.raises(SystemExit) as error:
            suite.run.run_main([*args, "--bare-first", other])
        assert error.value.code == 2
    assert "choose one" in capsys.readouterr().err


def test_suite_band_holds_each_seed_last_value():
    band = load_script("benchmarks/suite.py").plot.band
    curves = [[(1.0, 10.0), (3.0, 30.0)], [(2.0, 20.0)], []]
    low, mid, high = band(curves, [0.0, 1.0, 2.5, 3.0])
    assert low[0] != low[0] and mid[0] != mid[0]  # NaN before any curve starts
    assert (low[1:], mid[1:], high[1:]) == ([10.0, 10.0, 20.0], [10.0, 15.0, 25.0], [10.0, 20.0, 30.0])


def test_bytecode_finds_a_package_without_its_compiled_sources_and_with_them(harness, tmp_path, monkeypatch):
    """``harness.bytecode`` looks for the bytecode of a package's ``__init__.py`` (compileall writes
    it where pip install would), and the note names the packages without it."""
    package = tmp_path / "fakepkg" / "sub"
    package.mkdir(parents=True)
    (tmp_path / "fakepkg" / "__init__.py").write_text("")
    (package / "__init__.py").write_text("X = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    state = harness.bytecode(("fakepkg.sub", "no_such_package_here"))
    assert state["compiled"] == {"fakepkg.sub": False, "no_such_package_here": None}
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    note = harness.bytecode_note(harness.bytecode(("fakepkg.sub",)))
    assert "fakepkg.sub" in note and "every process compiles them again" in note
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(tmp_path / "fakepkg")], check=True)
    state = harness.bytecode(("fakepkg.sub",))
    assert state["compiled"] == {"fakepkg.sub": True}
    assert harness.bytecode_note(state) is None


@pytest.fixture(scope="module")
def parts():
    """``card_command.py parts``: the card's command in this process, its programs' compile log and
    MuJoCo Warp's callbacks timed."""
    return load_script("benchmarks/card_command.py").parts


def test_card_parts_reads_jax_compile_log_lines(parts):
    """The compile-log lines of JAX 0.10 and 0.11 (both wordings of tracing), summed by program and
    stage; cache hits matched to their program (``<lambda>`` is the cache's ``_lambda``)."""
    stages, hits = parts.CompileLog().stages, set()
    lines = [
        "Finished tracing scan_updates for jit in 1.5 sec",
        "Finished tracing + transforming scan_updates for pjit in 0.25 sec",
        "Finished jaxpr to MLIR module conversion jit(scan_updates) in 0.5 sec",
        "Persistent compilation cache hit for 'jit_scan_updates' with key 'jit_scan_updates-7d67'",
        "Finished XLA compilation of jit(scan_updates) in 0.625 sec",
        "Finished XLA compilation of jit(<lambda>) in 2e-3 sec",
        "Persistent compilation cache hit for 'jit__lambda' with key 'jit__lambda-5d6c'",
        "Compiling jit(scan_updates) with global shapes and types (ShapedArray(float32[3]),).",
        "an unrelated line in 3 sec",
    ]
    for line in lines:
        parts.parse_line(line, stages, hits)
    assert stages["scan_updates"] == {"tracing": 1.75, "lowering": 0.5, "compile": 0.625}
    assert stages["<lambda>"] == {"compile": 0.002}
    assert hits == {"scan_updates", "lambda"} and parts.plain_name("<lambda>") in hits


def test_card_parts_reads_this_jax_s_own_compile_log(parts):
    """The lines this JAX writes under ``jax.log_compiles`` give all three stages of a new program."""
    import jax

    log, logger = parts.CompileLog(), logging.getLogger("jax")
    logger.addHandler(log)
    try:
        with jax.log_compiles(True):
            jax.jit(lambda x: x * 3.0 + 0.25)(1.0)
    finally:
        logger.removeHandler(log)
    assert set(log.stages["<lambda>"]) == {"tracing", "lowering", "compile"}
    assert all(seconds > 0 for seconds in log.stages["<lambda>"].values())


def test_card_parts_times_each_ffi_call_and_keeps_its_result(parts, monkeypatch):
    ffi = pytest.importorskip("warp._src.jax.ffi")
    registered = {}
    monkeypatch.setattr(ffi, "_register_ffi_targets", lambda name, callback: registered.setdefault(name, callback))
    clock = parts.CallbackClock()
    assert parts.time_warp_callbacks(clock) is None
    outcomes = iter([None, 7, ValueError("an FFI error")])

    def handler(call_frame, platform):
        outcome = next(outcomes)
        if isinstance(outcome, Exception):
            raise outcome
        return outcome

    ffi._register_ffi_targets("step", handler)
    timed = registered["step"]
    assert timed("frame", "CUDA") is None and timed("frame", "CUDA") == 7
    with pytest.raises(ValueError, match="an FFI error"):
        timed("frame", "CUDA")
    summary = clock.summary()
    assert (summary["targets"], summary["calls"]) == (1, 3)
    assert summary["seconds"] == pytest.approx(summary["first_calls_s"] + summary["later_calls_s"])
    assert summary["first_calls_s"] == clock.calls["step"][0] and summary["later_median_us"] > 0
