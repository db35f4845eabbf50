"""Every command in the README's code blocks is exercised.

* The main job (the first command: NPG on ``inverted_pendulum`` into ``runs/pendulum``) runs for
  real, as written, and must balance the pendulum: its final mean-policy return >= 950. Then the
  README's ``python -m jaxpg.evaluate runs/pendulum ... --gymnasium`` replays it in Gymnasium's
  InvertedPendulum-v5 and must reach the same.
* The GPU training commands are planned as the CLI plans them (flags, preset, config validated
  against the task, env built) without training, which needs a GPU.
* ``python -m jaxpg.evaluate`` of a Pong run is run by ``tests/test_pong.py`` on a tiny run.
* The Pong benchmark's commands (``benchmarks/pong.py``, its own command line) pass that
  script's argument checks; ``tests/test_pong.py`` runs its comparison mode on the CPU.
* The several-process launch lines are run word for word by ``tests/test_distributed.py``.
* The install, test and venv steps are what ``.ci/run`` runs.

A python command of the README that none of these covers fails ``test_every_command_is_covered``.
"""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from script_loader import load_script

from jaxpg import cli

ROOT = Path(__file__).resolve().parents[1]
MAIN_JOB = "python experiments/pendulum.py --run-dir runs/pendulum"


def readme_python_commands() -> list[str]:
    """Every ``python ...`` command of the README's bash blocks (one per ``&&`` segment, comments
    and a trailing ``&`` dropped)."""
    text = (ROOT / "README.md").read_text()
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            line = line.split(" #")[0].strip()
            if line.startswith("#"):
                continue
            for segment in line.split("&&"):
                segment = segment.strip().rstrip("&").strip()
                if segment.startswith("python ") and not segment.startswith("python3 -m venv"):
                    commands.append(segment)
    return commands


def is_distributed(command: str) -> bool:
    return "--coordinator-address" in command


def is_pong_benchmark(command: str) -> bool:
    return shlex.split(command)[1] == "benchmarks/pong.py"


def is_pong_evaluation(command: str) -> bool:
    """``python -m jaxpg.evaluate runs/pong...``: tests/test_pong.py runs it on a tiny trained run."""
    return command.startswith("python -m jaxpg.evaluate runs/pong")


def is_ale_evaluation(command: str) -> bool:
    """``python -m jaxpg.evaluate RUN --ale``: tests/test_atari.py runs it on a tiny trained run."""
    return command.startswith("python -m jaxpg.evaluate ") and "--ale" in shlex.split(command)


def is_planned(command: str) -> bool:
    """A training command checked with ``cli.plan`` (everything but the main job)."""
    words = shlex.split(command)
    return command != MAIN_JOB and (words[1].startswith("experiments/") or words[1:3] == ["-m", "jaxpg.cli"])


COVERED_ELSEWHERE = (is_distributed, is_planned, is_pong_benchmark, is_pong_evaluation, is_ale_evaluation)


def test_every_command_is_covered():
    commands = readme_python_commands()
    assert MAIN_JOB in commands
    evaluates = [c for c in commands if c.startswith("python -m jaxpg.evaluate runs/pendulum")]
    assert evaluates, "the README evaluates the main job's run directory"
    uncovered = [
        c for c in commands if c != MAIN_JOB and c not in evaluates and not any(check(c) for check in COVERED_ELSEWHERE)
    ]
    assert not uncovered, f"README commands no test runs: {uncovered}"


def test_ci_runs_the_readme_test_command_and_reports_skips():
    """``.ci/run`` runs the README's second command word for word, and that command's pytest prints
    the reason of every skip (``-rs``), so that a skipped check is seen in CI's log."""
    readme = [line for line in (ROOT / "README.md").read_text().splitlines() if "pytest" in line]
    ci = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if "pytest" in line]
    assert len(readme) == 1 and ci == readme, (readme, ci)
    assert re.search(r"&& pytest -q -rs$", ci[0]), ci[0]


def load_experiment(script: str) -> cli.Experiment:
    """The ``EXPERIMENT`` of ``experiments/<name>.py``."""
    return load_script(script).EXPERIMENT


@pytest.mark.parametrize("command", [c for c in readme_python_commands() if is_planned(c) and not is_distributed(c)])
def test_training_commands_plan(command, tmp_path):
    words = shlex.split(command)
    argv = words[3:] if words[1] == "-m" else words[2:]
    experiment = cli.Experiment() if words[1] == "-m" else load_experiment(words[1])
    if "--run-dir" in argv:
        argv[argv.index("--run-dir") + 1] = str(tmp_path / "run")
    planned = cli.plan(argv, experiment)
    assert planned.config.num_envs >= 1 and planned.run.iterations >= 1


@pytest.mark.parametrize("command", [c for c in readme_python_commands() if is_pong_benchmark(c)])
def test_pong_benchmark_commands_pass_their_checks(command, tmp_path):
    bench = load_script("benchmarks/pong.py")
    argv = shlex.split(command)[2:]
    argv[argv.index("--run-dir") + 1] = str(tmp_path / "run")
    args = bench.build_parser().parse_args(argv)
    bench.check(args)
    assert args.compare_envs and not args.run_dir.exists()


@pytest.mark.slow
def test_main_job_balances_the_pendulum_and_gymnasium_agrees(tmp_path):
    words = shlex.split(MAIN_JOB)
    train = subprocess.run(
        [sys.executable, str(ROOT / words[1]), *words[2:]], cwd=tmp_path, capture_output=True, text=True, timeout=1200
    )
    assert train.returncode == 0, train.stderr[-3000:]
    rows = [json.loads(line) for line in (tmp_path / "runs" / "pendulum" / "metrics.jsonl").read_text().splitlines()]
    final = [r["return_mean_policy"] for r in rows if r.get("return_mean_policy") is not None][-1]
    assert float(final) >= 950, f"main job ended at mean-policy return {final}"
    for command in readme_python_commands():
        if command.startswith("python -m jaxpg.evaluate runs/pendulum"):
            words = shlex.split(command)
            out = subprocess.run(
                [sys.executable, *words[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=600
            )
            assert out.returncode == 0, out.stderr[-3000:]
            returns = re.findall(r"^return: ([0-9.]+)", out.stdout, flags=re.M)
            assert returns and float(returns[0]) >= 950, out.stdout
