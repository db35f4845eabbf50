"""Several processes train as one, through ``jax.distributed`` (CPU collectives over gloo).

Two processes on 127.0.0.1, one CPU device each, run the two command lines of docs/gpus.md's
"Several hosts" (``python -m jaxpg.cli ... --coordinator-address 127.0.0.1:7777 --num-processes 2
--process-id I``, on a free port and in a temporary run directory): the env batch is split over
the two devices of the two processes, and the metrics must equal those of one process on one
device (the same command without the three flags) up to float reduction order (see
``tests/test_sharding.py``).

What the comparison allows (``compare``): the two-process program sums in another float32 order
(its reductions span two devices), so its numbers may differ in the last bits, and what can be
compared depends on what amplifies those bits:
- Counts exactly, every iteration: the iteration number, env steps, rejected updates, evaluations.
- The first iteration starts both runs from the same state. What does not pass through the
  policy step (returns and lengths of the sampled episodes, mean reward, entropy, gradient norm,
  value loss) is float32 sums of at most a few thousand terms: rtol 1e-4 (relative difference
  <= ~1e-5). The step (KL, step length, the loss that includes the KL) solves ``(F + damping I) x = g``
  by conjugate gradient, which amplifies a relative perturbation by up to the condition number
  ``1 + lambda_max(F) / damping``: at the documented ``--cg-damping 0.01`` with ``lambda_max(F)`` of
  this policy 3.6-7 (computed densely over the first iterations) that is <= ~700, so those agree
  to ~7e-3 and are compared with rtol 3e-2. The evaluation after an iteration runs episodes of
  the new parameters, which can end a step earlier or later: compared as the later iterations.
  (At the default damping 1e-4 the condition number would be ~7e4 and nothing of the step could be
  compared.) The CG residual, itself round-off, is left out.
- Later iterations step from parameters that may differ in the last bits, and an episode can end
  a step earlier or later: no float tolerance follows from the computation. What a process that
  lost its share of the batch or its synchronisation would break is that the run's metrics lie far
  closer to the one-process run of its own seed than to that of another seed
  (``SEED_DISCRIMINATING``, checked to differ between seeds 0 and 1 by more than 5 %): within a
  tenth of that gap.
Measured (printed with ``-s``; AMD EPYC, JAX 0.10): <= 8e-7 relative on the first iteration (and on
the first resumed one), later within 5e-6 of the seed gap.
Only process 0 writes the run directory; every process restores the checkpoint on ``--resume``.
"""

from __future__ import annotations

import json
import os
import shlex
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from jaxpg import train as train_lib
from jaxpg.run.host.processes import DistributedConfig, DistributedError

ROOT = Path(__file__).resolve().parents[1]
README_ADDRESS, README_RUN_DIR = "127.0.0.1:7777", "runs/cartpole-2p"
DISTRIBUTED_FLAGS = ("--coordinator-address", "--num-processes", "--process-id")


def readme_commands() -> list[list[str]]:
    """The two launch commands of "Several hosts" in ``docs/gpus.md``, as argument lists after
    ``python -m jaxpg.cli``."""
    lines = [line.rstrip(" &") for line in (ROOT / "docs" / "gpus.md").read_text().splitlines()]
    commands = [
        shlex.split(line)[3:] for line in lines if line.startswith("python -m jaxpg.cli") and "--process-id" in line
    ]
    assert len(commands) == 2, commands
    return commands


def drop_options(args: list[str], names: tuple[str, ...]) -> list[str]:
    """``args`` without the options ``names`` and their values."""
    out, skip = [], False
    for arg in args:
        if skip:
            skip = False
        elif arg in names:
            skip = True
        else:
            out.append(arg)
    return out


def option(args: list[str], name: str) -> str:
    return args[args.index(name) + 1]


ARGS = drop_options(readme_commands()[0], (*DISTRIBUTED_FLAGS, "--run-dir"))  # the one-process command
ITERATIONS = int(option(ARGS, "--iterations"))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cpu_env(devices: int = 1) -> dict[str, str]:
    return {
        **os.environ,
        "JAX_PLATFORMS": "cpu",
        # kept: other XLA flags (e.g. ``--xla_cpu_max_isa``) of the caller
        "XLA_FLAGS": f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count={devices}",
        "PYTHONUNBUFFERED": "1",
    }


def cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "jaxpg.cli", *args]


# Hang guards, not speed requirements: a slow machine may take minutes to compile a training run.
HANG_GUARD_S = 900


def launch(commands: list[list[str]], envs: list[dict[str, str]], timeout: float = HANG_GUARD_S) -> list:
    """Run the processes ``python -m jaxpg.cli <commands[i]>`` together; their results."""
    procs = [
        subprocess.Popen(cli(*args), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        for args, env in zip(commands, envs, strict=True)
    ]
    results = []
    try:
        for proc in procs:
            out, err = proc.communicate(timeout=timeout)
            results.append(subprocess.CompletedProcess(proc.args, proc.returncode, out, err))
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
    return results


def run_processes(args: list[str], count: int = 2, timeout: float = HANG_GUARD_S) -> list[subprocess.CompletedProcess]:
    """``count`` processes of ``args``, told where the coordinator is by ``JAX_COORDINATOR_ADDRESS``,
    ``JAX_NUM_PROCESSES`` and ``JAX_PROCESS_ID`` (docs/gpus.md's alternative to the flags)."""
    address = f"127.0.0.1:{free_port()}"
    env = {**cpu_env(), "JAX_COORDINATOR_ADDRESS": address, "JAX_NUM_PROCESSES": str(count)}
    return launch([args] * count, [{**env, "JAX_PROCESS_ID": str(i)} for i in range(count)], timeout)


def metrics(run_dir: Path) -> list[dict]:
    return [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]


COUNTS = ("iteration", "env_steps", "update_rejected", "consecutive_failures", "evaluated")
THROUGH_STEP = ("kl", "step_length", "step_fraction", "loss")
NOT_COMPARED = ("wall_time_s", "eval_seconds", "cg_residual")  # host time; CG round-off
SEED_DISCRIMINATING = ("value_loss", "grad_norm")


def compare(reference: list[dict], other: list[dict], other_seed: list[dict], first: int) -> tuple[float, float]:
    """Assert the module docstring's comparison of ``other``'s metric rows with ``reference``'s (the
    same seed) and ``other_seed``'s (another seed), aligned by iteration; ``first`` is the
    iteration from which both started from the same state. Returns the largest relative
    difference on that first iteration and, on the later ones, the largest share of the seed gap."""
    assert (
        [r["iteration"] for r in other] == [r["iteration"] for r in reference] == [r["iteration"] for r in other_seed]
    )
    first_worst, later_worst = 0.0, 0.0
    for ref, row, seed_row in zip(reference, other, other_seed, strict=True):
        where = f"iteration {ref['iteration']}"
        for key in COUNTS:
            assert row.get(key) == ref.get(key), (key, where)
        for key in SEED_DISCRIMINATING:
            own_gap, seed_gap = abs(row[key] - ref[key]), abs(seed_row[key] - ref[key])
            assert seed_gap > 0.05 * abs(ref[key]), (key, where, ref[key], seed_row[key])  # the seeds do differ
            assert own_gap < 0.1 * seed_gap, (key, where, row[key], ref[key], seed_row[key])
            if ref["iteration"] > first:
                later_worst = max(later_worst, own_gap / seed_gap)
        if ref["iteration"] != first:
            continue
        for key, value in ref.items():
            if key in NOT_COMPARED or key in COUNTS or key in train_lib.EVAL_METRICS or value is None:
                continue
            rtol = 3e-2 if key in THROUGH_STEP else 1e-4
            np.testing.assert_allclose(row[key], value, rtol=rtol, atol=1e-5, err_msg=f"{key} {where}")
            first_worst = max(first_worst, abs(row[key] - value) / max(abs(value), 1e-6))
    return first_worst, later_worst


@pytest.fixture(scope="module")
def one_process(tmp_path_factory) -> Path:
    """The reference: the documented command as one process on one device; checkpoints at 2 and 4."""
    run_dir = tmp_path_factory.mktemp("one") / "run"
    args = [*ARGS, "--checkpoint-every", "2", "--run-dir", str(run_dir)]
    proc = subprocess.run(cli(*args), capture_output=True, text=True, env=cpu_env(), timeout=HANG_GUARD_S)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return run_dir


@pytest.fixture(scope="module")
def other_seed(tmp_path_factory) -> list[dict]:
    """The scale of what a mix-up would change: the one-process run's metrics with ``--seed 1``."""
    run_dir = tmp_path_factory.mktemp("seed1") / "run"
    args = [*drop_options(ARGS, ("--seed",)), "--seed", "1", "--run-dir", str(run_dir)]
    proc = subprocess.run(cli(*args), capture_output=True, text=True, env=cpu_env(), timeout=HANG_GUARD_S)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return metrics(run_dir)


def check_only_process_0_wrote(results: list[subprocess.CompletedProcess], run_dir: Path) -> None:
    assert all(r.returncode == 0 for r in results), "\n".join(r.stderr[-2000:] for r in results)
    assert "run directory:" in results[0].stdout
    # Process 1 prints nothing of its own (gloo announces its connections itself).
    assert [line for line in results[1].stdout.splitlines() if not line.startswith("[Gloo]")] == []
    assert len(metrics(run_dir)) == ITERATIONS  # one writer: every iteration once


def test_two_processes_train_like_one(one_process, other_seed, tmp_path):
    """The documented two commands, on a free port and into a temporary run directory."""
    run_dir, address = tmp_path / "run", f"127.0.0.1:{free_port()}"
    commands = readme_commands()
    assert [drop_options(c, DISTRIBUTED_FLAGS) for c in commands] == [drop_options(commands[0], DISTRIBUTED_FLAGS)] * 2
    assert [option(c, "--process-id") for c in commands] == ["0", "1"]
    substitute = {README_ADDRESS: address, README_RUN_DIR: str(run_dir)}
    commands = [[substitute.get(arg, arg) for arg in c] for c in commands]
    start = time.perf_counter()
    results = launch(commands, [cpu_env()] * 2)
    check_only_process_0_wrote(results, run_dir)
    assert "2 cpu device(s) in 2 processes" in results[0].stdout
    assert sorted(p.name for p in (run_dir / "checkpoints").iterdir() if p.name.isdigit()) == [str(ITERATIONS)]
    first, later = compare(metrics(one_process), metrics(run_dir), other_seed, first=1)
    print(
        f"\n1 vs 2 processes: largest relative difference {first:.1e} on iteration 1, later {later:.1e} of the "
        f"seed gap ({time.perf_counter() - start:.0f} s)"
    )


def test_two_processes_resume_a_run(one_process, other_seed, tmp_path):
    """Every process restores the one-process run's checkpoint 2 and they continue it together to
    iteration 4, as the one process did (told about each other by environment variables)."""
    run_dir = tmp_path / "run"
    shutil.copytree(one_process, run_dir)
    shutil.rmtree(run_dir / "checkpoints" / str(ITERATIONS))
    results = run_processes(["--resume", str(run_dir), "--iterations", str(ITERATIONS)])
    check_only_process_0_wrote(results, run_dir)
    assert "resuming at iteration 2" in results[0].stdout
    first, later = compare(metrics(one_process), metrics(run_dir), other_seed, first=3)  # 3: from checkpoint 2
    print(f"\nresumed by 2 processes: {first:.1e} relative on iteration 3, {later:.1e} of the seed gap later")


def test_unreachable_coordinator_fails_with_one_line(tmp_path):
    """A process whose coordinator never answers gives up after ``--distributed-timeout`` (the error
    line names it) with status 2 and one line, and writes nothing."""
    proc = subprocess.run(
        cli(*ARGS, "--run-dir", str(tmp_path / "run"), "--coordinator-address", f"127.0.0.1:{free_port()}",
            "--num-processes", "2", "--process-id", "1", "--distributed-timeout", "2"),
        capture_output=True, text=True, env=cpu_env(), timeout=HANG_GUARD_S,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr[-2000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: cannot reach the coordinator at 127.0.0.1:"), proc.stderr
    assert "within 2 s" in lines[0], lines[0]
    assert not (tmp_path / "run").exists()


def test_batch_must_split_over_all_processes(tmp_path):
    args = [*drop_options(ARGS, ("--num-envs",)), "--num-envs", "15"]
    results = run_processes([*args, "--run-dir", str(tmp_path / "run")])
    for result in results:
        assert result.returncode == 2, result.stderr[-2000:]
        assert "error: --num-envs 15 is not divisible by the 2 devices (2 processes)" in result.stderr
    assert not (tmp_path / "run").exists()


def test_settings_from_flags_or_environment():
    assert DistributedConfig.resolve(environ={}) is None
    assert DistributedConfig.resolve(num_processes=1, environ={}) is None
    env = {"JAX_COORDINATOR_ADDRESS": "10.0.0.1:1234", "JAX_NUM_PROCESSES": "4", "JAX_PROCESS_ID": "3"}
    assert DistributedConfig.resolve(environ=env) == DistributedConfig("10.0.0.1:1234", 4, 3)
    flags = DistributedConfig.resolve("h:99", 2, 0, timeout_s=5, environ=env)  # flags win
    assert flags == DistributedConfig("h:99", 2, 0, timeout_s=5)
    assert DistributedConfig("[::1]:99", 2, 0).host_port == ("::1", 99)
    for kwargs, message in (
        (dict(num_processes=2, environ={}), "need --coordinator-address"),
        (dict(coordinator_address="h", num_processes=2, process_id=0, environ={}), "must be host:port"),
        (dict(coordinator_address="h:1", num_processes=2, process_id=2, environ={}), "must be in 0..1"),
        (dict(environ={"JAX_PROCESS_ID": "x"}), "JAX_PROCESS_ID must be an integer"),
    ):
        with pytest.raises(DistributedError, match=message):
            DistributedConfig.resolve(**kwargs)
