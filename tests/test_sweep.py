"""``jaxpg.sweep``: a tiny sweep end to end (2 configurations x 2 seeds of NPG on the inverted
pendulum's small shapes), interrupted after its first chunk and resumed; its scores against a
NumPy replay in Gymnasium; the same sweep sharded over two processes; and bad specs refused with
one ``error:`` line before anything compiles.

The sweep trains in chunks of two runs (``runs_per_chunk=2``): config 0's two seeds, then config 1's.
``max_chunks=1`` stops the first call after one chunk, as an interruption at a chunk boundary
leaves the directory (a chunk interrupted midway left no record and is trained again).
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from jaxpg.sweep import SpecError, SweepSpec, cli, run_sweep
from jaxpg.sweep.store import SweepStore, leaves

SMALL = {"num_envs": 4, "horizon": 16, "policy_hidden": [8], "value_hidden": [8], "value_batch_size": 16}
SPEC = SweepSpec(
    task="inverted_pendulum",
    algo="npg",
    overrides=SMALL,
    grid={"kl_delta": [0.01, 0.05]},
    seeds=(0, 1),
    iterations=4,
)
EPISODES = 2
CLI_ARGS = [
    "--task", "inverted_pendulum", "--algo", "npg", "--set", "num_envs=4", "--set", "horizon=16",
    "--set", "policy_hidden=[8]", "--set", "value_hidden=[8]", "--set", "value_batch_size=16",
    "--grid", "kl_delta=0.01,0.05", "--seeds", "2", "--iterations", "4", "--episodes", str(EPISODES),
    "--workers", "0", "--runs-per-chunk", "2", "--no-figures",
]  # fmt: skip


@pytest.fixture(scope="module")
def swept(tmp_path_factory) -> tuple[Path, dict]:
    """The sweep, run as an interrupted call and a resumed one; ``(directory, facts)``."""
    out = tmp_path_factory.mktemp("sweep") / "out"
    first = run_sweep(SPEC, out, runs_per_chunk=2, episodes=EPISODES, workers=0, max_chunks=1, figures=False)
    store = SweepStore(out)
    facts = {
        "first_result": first,
        "first_chunks": store.chunk_names(),
        "first_runs": store.finished_runs(),
        "first_bytes": {p.name: p.read_bytes() for p in store.chunks.iterdir()},
    }
    facts["report"] = run_sweep(SPEC, out, runs_per_chunk=2, episodes=EPISODES, workers=1)
    return out, facts


def test_interrupted_sweep_resumes_without_redoing_runs(swept):
    out, facts = swept
    assert facts["first_result"] is None  # runs were left
    assert facts["first_chunks"] == ["chunk-00000"] and facts["first_runs"] == {0, 1}
    store = SweepStore(out)
    assert store.chunk_names() == ["chunk-00000", "chunk-00001"]
    runs = [r["runs"] for r in store.records()]
    assert runs == [[0, 1], [2, 3]]  # the resumed call trained only the runs left
    for name, content in facts["first_bytes"].items():
        assert (store.chunks / name).read_bytes() == content, name  # the first chunk untouched
    assert store.scores("chunk-00000") is not None and store.scores("chunk-00001") is not None


def test_sweep_tables(swept):
    out, facts = swept
    report = facts["report"]
    runs = list(csv_rows(out / "runs.csv"))
    assert [(int(r["configuration"]), int(r["seed"])) for r in runs] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert [float(r["kl_delta"]) for r in runs] == [0.01, 0.01, 0.05, 0.05]
    curves = list(csv_rows(out / "curves.csv"))
    assert len(curves) == 4 * SPEC.iterations
    first = {(int(r["configuration"]), int(r["seed"])): float(r["return"]) for r in curves if r["iteration"] == "1"}
    # The first iteration samples with the initial policy, which depends on the seed alone.
    assert first[(0, 0)] == first[(1, 0)] and first[(0, 1)] == first[(1, 1)]
    assert first[(0, 0)] != first[(0, 1)]
    steps = [float(r["env_steps"]) for r in curves if r["run"] == "0"]
    assert steps == [64.0 * i for i in range(1, SPEC.iterations + 1)]
    configs = list(csv_rows(out / "configurations.csv"))
    for row in configs:
        scores = [float(r["score"]) for r in runs if r["configuration"] == row["configuration"]]
        assert float(row["mean"]) == pytest.approx(np.mean(scores))
        assert float(row["median"]) == pytest.approx(np.median(scores))
        assert float(row["iqm"]) == pytest.approx(np.mean(scores))  # 2 seeds: nothing trimmed
        assert float(row["iqm_low"]) <= float(row["iqm"]) <= float(row["iqm_high"])
        assert min(scores) <= float(row["iqm_low"]) and float(row["iqm_high"]) <= max(scores)
    assert "kl_delta=0.01" in report.table()
    assert {p.name for p in (out / "figures").iterdir()} == {
        "return_vs_env_steps.png",
        "return_vs_wall_clock.png",
        "sensitivity_kl_delta.png",
    }
    summary = json.loads((out / "summary.json").read_text())
    assert summary["timing"]["runs"] == 4


def csv_rows(path: Path):
    import csv

    with path.open() as f:
        yield from csv.DictReader(f)


def numpy_policy(params: list[np.ndarray]):
    """The trained Gaussian policy's mean action in NumPy float32: leaves ``log_std, b0, w0, b1,
    w1`` of a one-hidden-layer tanh MLP, clipped to the pendulum's [-3, 3]."""
    _, b0, w0, b1, w1 = (np.asarray(x, np.float32) for x in params)
    return lambda obs: np.clip(np.tanh(np.asarray(obs, np.float32) @ w0 + b0) @ w1 + b1, -3.0, 3.0)


def test_scores_are_gymnasium_returns_of_the_final_mean_policy(swept):
    """Each run's score against its final parameters played in Gymnasium's InvertedPendulum-v5 by a
    NumPy forward pass: the mean return over the episodes from seeds ``seed, seed + 1``. The replay
    rounds the actions apart from the float32 program only in the last bits, which can move an
    episode's end (the pole's angle crossing 0.2) by a step: one step of reward 1 at most."""
    import gymnasium

    out, _ = swept
    store = SweepStore(out)
    runs = {int(r["run"]): r for r in csv_rows(out / "runs.csv")}
    for name in store.chunk_names():
        record, arrays = store.load_chunk(name)
        for row, index in enumerate(record["runs"]):
            policy = numpy_policy([x[row] for x in leaves(arrays, "params")])
            seed = int(runs[index]["seed"])
            env = gymnasium.make("InvertedPendulum-v5")
            returns = []
            for episode in range(EPISODES):
                obs, _ = env.reset(seed=seed + episode)
                total, done = 0.0, False
                while not done:
                    obs, reward, terminated, truncated, _ = env.step(policy(obs))
                    total, done = total + reward, terminated or truncated
                returns.append(total)
            env.close()
            assert abs(float(runs[index]["score"]) - np.mean(returns)) <= 1.0, index


def test_resume_with_another_spec_is_refused(swept, capsys):
    out, _ = swept
    code = cli.main([*CLI_ARGS, "--seeds", "3", "--out", str(out)])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "another sweep" in err[0]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--grid", "kl_deltaa=0.1,0.2"], "unknown field 'kl_deltaa'"),
        (["--grid", "kl_delta=0.1,-1"], "kl_delta must be > 0"),
        (["--grid", "horizon=16,32", "--max-programs", "1"], "horizon change shapes or structure"),
        (["--grid", "num_envs=4,x"], "'num_envs' must be an integer"),
        (["--log-uniform", "cg_damping=0:1", "--samples", "2"], "low > 0 for log"),
    ],
)
def test_bad_specs_get_one_error_line(extra, message, tmp_path, capsys, monkeypatch):
    import jax

    compiled = []
    monkeypatch.setattr(jax.stages.Lowered, "compile", lambda *a, **k: compiled.append(a))
    out = tmp_path / "out"
    code = cli.main([*CLI_ARGS, *extra, "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("error:") and message in err[0], err
    assert not out.exists() and not compiled


def test_spec_errors_are_spec_errors():
    import jaxpg.sweep

    with pytest.raises(SpecError, match="unknown field 'nope' of ppo's Config"):
        jaxpg.sweep(SweepSpec(task="cartpole", algo="ppo", grid={"nope": [1]}), "unused")  # the module is callable
    with pytest.raises(SpecError, match="samples needs ranges"):
        SweepSpec(task="cartpole", algo="ppo", samples=3).expand()
    with pytest.raises(SpecError, match="unknown algorithm"):
        SweepSpec(task="cartpole", algo="ddpg").expand()


def test_two_processes_share_a_sweep(tmp_path):
    """A sweep over two processes of one CPU device each (``jax.distributed``; cartpole, whose env
    holds no MJX model: MJX places a model on ``jax.devices()[0]``, which in a process other than 0
    is another process's device): each chunk of two runs is split one run per process. It holds
    the runs of the one-process sweep, and its first iteration, sampled with the initial policies,
    gives that sweep's returns (the same float32 program for each run, to reduction order: rtol
    1e-5); process 0 scores them all."""
    args = [arg.replace("inverted_pendulum", "cartpole") for arg in CLI_ARGS]
    one = tmp_path / "one"
    assert cli.main([*args, "--out", str(one)]) == 0
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    two = tmp_path / "two"
    env = {**os.environ, "JAX_PLATFORMS": "cpu", "PYTHONUNBUFFERED": "1"}
    env["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count=1"
    common = [*args, "--out", str(two), "--coordinator-address", f"127.0.0.1:{port}", "--num-processes", "2"]
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "jaxpg.sweep", *common, "--process-id", str(i)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        for i in range(2)
    ]
    results = []
    try:
        for proc in procs:
            results.append(proc.communicate(timeout=900))  # a hang guard, not a speed requirement
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
    for proc, (_, stderr) in zip(procs, results, strict=True):
        assert proc.returncode == 0, stderr[-3000:]
    assert "on 2 device(s)" in results[0][0]
    ones = {(r["run"], r["iteration"]): float(r["return"]) for r in csv_rows(one / "curves.csv")}
    twos = {(r["run"], r["iteration"]): float(r["return"]) for r in csv_rows(two / "curves.csv")}
    assert set(ones) == set(twos)
    for run in ("0", "1", "2", "3"):
        assert twos[(run, "1")] == pytest.approx(ones[(run, "1")], rel=1e-5)
    rows = list(csv_rows(two / "runs.csv"))
    assert len(rows) == 4 and all(r["score"] for r in rows)


def test_sweep_speed_quick(tmp_path, capsys):
    """``benchmarks/sweep_speed.py --quick`` (the GPU benchmark at tiny sizes on cartpole): the
    sweep of 4 configurations x 2 seeds and one sequential run in its own process; its table and
    JSON hold the counts and the ratios as the seconds give them."""
    from script_loader import load_script

    bench = load_script("benchmarks/sweep_speed.py")
    assert bench.main(["--quick", "--case", "npg", "--sequential", "1", "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "sweep_speed.json").read_text())
    (result,) = data["results"]
    assert result["sweep"]["runs"] == 8 and len(result["sequential"]) == 1
    assert result["sweep_s_per_run"] == pytest.approx(result["sweep"]["wall_s"] / 8)
    assert result["speedup"] == pytest.approx(result["sequential_process_s_per_run"] / result["sweep_s_per_run"])
    assert result["sequential_extrapolated_s"] == pytest.approx(8 * result["sequential_process_s_per_run"])
    assert "speed-up" in capsys.readouterr().out


def test_sweep_killed_midway_resumes_each_run_once(tmp_path):
    """``python -m jaxpg.sweep`` (cartpole, one run a chunk) killed with SIGKILL once its second
    chunk is recorded, wherever it then is (training a chunk, writing one, scoring), and run again:
    every run ends in exactly one chunk, and the chunks recorded before the kill are kept as they
    were."""
    import signal
    import time

    args = [arg.replace("inverted_pendulum", "cartpole") for arg in CLI_ARGS]
    args[args.index("--runs-per-chunk") + 1] = "1"
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "jaxpg.sweep", *args, "--out", str(out)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)  # fmt: skip
    second = out / "chunks" / "chunk-00001.json"
    deadline = time.monotonic() + 900  # a hang guard, not a speed requirement
    while not second.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    store = SweepStore(out)
    kept = {name: (store.chunks / f"{name}.npz").read_bytes() for name in store.chunk_names()}
    assert len(kept) >= 2
    assert cli.main([*args, "--out", str(out)]) == 0
    runs = [run for record in store.records() for run in record["runs"]]
    assert sorted(runs) == [0, 1, 2, 3]
    for name, content in kept.items():
        assert (store.chunks / f"{name}.npz").read_bytes() == content
    assert len(list(csv_rows(out / "runs.csv"))) == 4
