"""``benchmarks/harness.py``'s command line for scripts with modes, and the scripts that use it."""

from __future__ import annotations

import subprocess
import sys

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


@pytest.mark.parametrize("script", ["throughput", "time_to_return", "card_command"])
def test_the_scripts_with_modes_name_them_when_run_without_one(script):
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / f"{script}.py")], capture_output=True, text=True, cwd=ROOT
    )
    modes = load_script(f"benchmarks/{script}.py").MODES
    assert proc.returncode == 1
    assert (
        proc.stderr.strip().splitlines()[-1] == f"usage: python benchmarks/{script}.py {{{','.join(modes)}}} [options]"
    )
