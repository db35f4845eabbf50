"""``benchmarks/step_latency.py``: its command line, a row's arithmetic, the XLA flags each child
gets, the trace summary on a hand-made trace, and one tiny run on MuJoCo Warp (CPU: Hopper, 2 envs,
graph mode NONE) through a child process, as on a GPU."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest
from script_loader import ROOT, load_script, python_path


@pytest.fixture(scope="module")
def latency():
    return load_script("benchmarks/step_latency.py")


def test_defaults_are_the_plan_every_mode_and_every_command_buffer_setting(latency):
    args = latency.parse_args([])
    assert args.pairs == [("hopper", 256), ("hopper", 16), ("hopper", 4096), ("ant", 256), ("humanoid", 256)]
    assert args.modes == ["WARP", "NONE", "JAX", "WARP_STAGED", "WARP_STAGED_EX"]
    assert args.command_buffers == ["default", "off", "on"]
    assert (args.steps, args.repeats, args.profile, args.json) == (100, 5, None, None)


def test_subsets_cross_tasks_with_env_counts_and_modes_are_case_blind(latency):
    args = latency.parse_args(["--tasks", "ant", "hopper", "--envs", "16", "32", "--modes", "jax", "warp_staged"])
    assert args.pairs == [("ant", 16), ("ant", 32), ("hopper", 16), ("hopper", 32)]
    assert args.modes == ["JAX", "WARP_STAGED"]
    # one list given: the other takes the plan's values
    assert latency.parse_args(["--envs", "8"]).pairs == [("hopper", 8), ("ant", 8), ("humanoid", 8)]
    assert latency.parse_args(["--tasks", "ant"]).pairs == [("ant", 256), ("ant", 16), ("ant", 4096)]
    quick = latency.parse_args(["--quick", "--steps", "3"])
    assert (quick.pairs, quick.modes, quick.command_buffers, quick.steps, quick.repeats) == (
        [("hopper", 2)],
        ["NONE"],
        ["off"],
        3,
        1,
    )


@pytest.mark.parametrize(
    "argv",
    [["--envs", "0"], ["--steps", "-1"], ["--modes", "CUDA"], ["--command-buffers", "maybe"], ["--json", "/no/dir/x"]],
)
def test_bad_options_exit_with_status_2(latency, argv, capsys):
    with pytest.raises(SystemExit) as stop:
        latency.parse_args(argv)
    assert stop.value.code == 2
    assert "error:" in capsys.readouterr().err


def test_work_runs_the_first_pair_under_every_setting_first(latency):
    pairs = [("hopper", 256), ("ant", 16)]
    assert latency.work(pairs, ["WARP", "JAX"], ["off", "on"]) == [
        ("off", "WARP", "hopper", 256),
        ("off", "JAX", "hopper", 256),
        ("on", "WARP", "hopper", 256),
        ("on", "JAX", "hopper", 256),
        ("off", "WARP", "ant", 16),
        ("off", "JAX", "ant", 16),
        ("on", "WARP", "ant", 16),
        ("on", "JAX", "ant", 16),
    ]


def test_a_child_reads_back_the_items_its_parent_asks_for(latency):
    args = latency.parse_args(["--steps", "7", "--repeats", "3"])
    items = [("on", "WARP_STAGED_EX", "hopper", 16), ("on", "JAX", "ant", 256)]
    command = latency.child_command(args, "on", items)
    assert command[:2] == [sys.executable, str(ROOT / "benchmarks" / "step_latency.py")]
    child = latency.parse_args(command[2:])
    assert child.child and child.items == [("WARP_STAGED_EX", "hopper", 16), ("JAX", "ant", 256)]
    assert (child.command_buffers, child.steps, child.repeats) == (["on"], 7, 3)


def test_a_dead_child_costs_its_row_and_a_fresh_child_takes_the_rest(latency, monkeypatch, tmp_path, capsys):
    """The parent's bookkeeping, with children that print given rows and end as told."""
    calls = []

    def fake_child(command, env, row_timeout, deadline):
        child = latency.parse_args(command[2:])
        calls.append((child.command_buffers[0], child.items, env["XLA_FLAGS"]))
        setting = child.command_buffers[0]
        rows = [{"task": t, "envs": n, "mode": m, "command_buffers": setting, "error": "x"} for m, t, n in child.items]
        if len(calls) == 1:  # the first child dies on its second item
            return rows[:1], {"device": "d", "backend": "b", "jax": "j", "mujoco": "m", "warp-lang": "w"}, "exit 1"
        return rows, None, "ok"

    monkeypatch.setattr(latency, "run_child", fake_child)
    monkeypatch.setenv("XLA_FLAGS", "")
    out = tmp_path / "rows.json"
    argv = ["--tasks", "hopper", "--envs", "8", "--modes", "NONE", "WARP", "JAX", "--command-buffers", "default", "on"]
    latency.main([*argv, "--json", str(out)])
    assert [(setting, len(items)) for setting, items, _ in calls] == [("default", 3), ("default", 1), ("on", 3)]
    assert calls[1][1] == [("JAX", "hopper", 8)] and (calls[0][2], calls[2][2]) == ("", latency.xla_flags("on", ""))
    rows = json.loads(out.read_text())["rows"]
    assert [(r["command_buffers"], r["mode"]) for r in rows] == [
        ("default", "NONE"),
        ("default", "WARP"),
        ("default", "JAX"),
        ("on", "NONE"),
        ("on", "WARP"),
        ("on", "JAX"),
    ]
    assert rows[1]["error"] == "child ended: exit 1"


def test_a_child_silent_too_long_is_killed_and_its_rows_kept(latency):
    row = {"task": "hopper", "envs": 2, "mode": "NONE", "command_buffers": "off", "error": "e"}
    code = f"import json, time; print('ROW ' + json.dumps({row!r}), flush=True); time.sleep(60)"
    start = time.perf_counter()
    rows, environment, ended = latency.run_child([sys.executable, "-c", code], dict(os.environ), 1.0, start + 60)
    assert (rows, environment, ended) == ([row], None, "no row within 1 s")
    rows, _, ended = latency.run_child([sys.executable, "-c", code], dict(os.environ), 60.0, time.perf_counter() + 3)
    assert (rows, ended) == ([row], "the budget ran out")
    assert time.perf_counter() - start < 30


def test_a_rows_figures_from_its_timing(latency):
    # 100 env steps of 256 envs, 4 physics steps each, in 0.2 s: 0.2 s / 400 = 0.5 ms per physics
    # step, 2 ms per env step, 25,600 env steps / 0.2 s = 128,000 env steps/s.
    row = latency.figures(0.2, steps=100, envs=256, frame_skip=4)
    assert row == pytest.approx({"ms_per_physics_step": 0.5, "ms_per_env_step": 2.0, "env_steps_per_s": 128_000.0})


def test_command_buffer_settings_become_xla_flags_and_a_users_flag_is_kept(latency):
    assert latency.xla_flags("off", "") == "--xla_gpu_enable_command_buffer="
    assert latency.xla_flags("default", "--xla_foo=1") == "--xla_foo=1"
    on = latency.xla_flags("on", "--xla_foo=1")
    assert on == "--xla_foo=1 --xla_gpu_enable_command_buffer=+WHILE,+CONDITIONAL"
    mine = "--xla_gpu_enable_command_buffer=FUSION"
    assert latency.xla_flags("off", mine) == mine
    assert latency.xla_flags("on", "", profiling=True).endswith(" --xla_enable_command_buffers_during_profiling=true")
    assert "profiling" not in latency.xla_flags("off", "", profiling=True)


def test_trace_summary_counts_kernels_and_gaps_per_stream(latency):
    gpu, cpu = 7, 8
    events = [
        {"ph": "M", "name": "process_name", "pid": gpu, "args": {"name": "/device:GPU:0"}},
        {"ph": "M", "name": "process_name", "pid": cpu, "args": {"name": "/host:CPU"}},
        # stream 1: kernels at [0, 10], [15, 20], [30, 34] us: gaps 5 and 10
        {"ph": "X", "pid": gpu, "tid": 1, "ts": 0.0, "dur": 10.0, "name": "a"},
        {"ph": "X", "pid": gpu, "tid": 1, "ts": 30.0, "dur": 4.0, "name": "MemcpyDtoH"},
        {"ph": "X", "pid": gpu, "tid": 1, "ts": 15.0, "dur": 5.0, "name": "b"},
        # stream 2: one kernel [12, 16], overlapping nothing of stream 1 but [15, 16]
        {"ph": "X", "pid": gpu, "tid": 2, "ts": 12.0, "dur": 4.0, "name": "d"},
        {"ph": "X", "pid": cpu, "tid": 1, "ts": 0.0, "dur": 100.0, "name": "host work"},
    ]
    summary = latency.trace_summary({"traceEvents": events}, physics_steps=2)
    # busy: [0, 10] + [12, 20] + [30, 34] = 22 us of a 34 us span
    assert summary == pytest.approx(
        {
            "kernels": 4,
            "kernels_per_physics_step": 2.0,
            "copies_per_physics_step": 0.5,
            "span_us_per_physics_step": 17.0,
            "busy_share": 22 / 34,
            "median_gap_us": 7.5,
            "gap_us_per_physics_step": 7.5,
            "streams": 2,
        }
    )
    assert latency.trace_summary({"traceEvents": events[1:2]}, 2)["kernels"] == 0


def test_an_unknown_task_is_one_error_line_and_status_2():
    proc = subprocess.run(
        [sys.executable, "benchmarks/step_latency.py", "--tasks", "hoper", "--envs", "2"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": python_path()},
    )
    assert proc.returncode == 2
    [line] = proc.stderr.strip().splitlines()
    assert line.startswith("error: unknown task 'hoper'; known: ") and "hopper" in line


def test_warp_graph_mode_reaches_mjx_model():
    from jaxpg import envs
    from jaxpg.envs.mjx_env import warp_available

    if not warp_available():
        pytest.skip("warp-lang is not installed (pip install 'jaxpg[warp]')")
    import warp

    task = envs.make_task("hopper", impl="warp", max_batch=2, warp_graph_mode="warp_staged")
    assert task.mjx_model.opt._impl.graph_mode == warp.JaxCallableGraphMode.WARP_STAGED


def test_quick_run_measures_hopper_on_warp_in_a_child(tmp_path):
    from jaxpg.envs.mjx_env import warp_available

    if not warp_available():
        pytest.skip("warp-lang is not installed (pip install 'jaxpg[warp]')")
    out = tmp_path / "rows.json"
    proc = subprocess.run(
        [sys.executable, "benchmarks/step_latency.py", "--quick", "--json", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": python_path(), "JAX_PLATFORMS": "cpu"},
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    data = json.loads(out.read_text())
    assert data["environment"]["backend"] == "cpu" and data["meta"]["steps"] == 2
    [row] = data["rows"]
    assert (row["task"], row["envs"], row["mode"], row["command_buffers"], row["frame_skip"]) == (
        "hopper",
        2,
        "NONE",
        "off",
        4,
    )
    assert row["finite"] and "error" not in row
    # the row's figures follow from its own median call time: 2 env steps of 2 envs, 4 physics steps each
    assert row["ms_per_physics_step"] == pytest.approx(1e3 * row["call_s"] / 8)
    assert row["env_steps_per_s"] == pytest.approx(4 / row["call_s"])
    assert "| hopper | 2 | NONE | off |" in proc.stdout
