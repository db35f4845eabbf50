"""``curves.png`` drawn by a helper process (``jaxpg.run.outputs.plot_process``): the helper draws what the
training process would have drawn, reports its failures as warning lines, skips a periodic drawing
while it is busy, and where it dies the drawings go on in the training process. No JAX program is
compiled here."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from jaxpg.run.outputs import plot_process, plotting
from jaxpg.run.rundir import config_io, layout


def history_of(num_iterations: int, num_seeds: int = 2) -> plotting.CurveHistory:
    """Returns that rise with the iteration, a NaN in the first seed's mean-policy curve."""
    history = plotting.CurveHistory()
    if num_iterations == 0:
        return history
    returns = np.arange(num_iterations * num_seeds, dtype=np.float64).reshape(num_iterations, num_seeds)
    mean_policy = returns + 0.5
    mean_policy[0, 0] = np.nan
    history.add_block({"return_stochastic": returns, "return_mean_policy": mean_policy}, 0)
    return history


@pytest.fixture
def run_dir(tmp_path):
    """A run directory with its config (what ``plot_run`` reads for the title)."""
    run = config_io.RunConfig(task="hopper", algo="npg", config={}, seeds=[0, 1], iterations=5)
    run.save(tmp_path)
    return tmp_path


def png_size(path) -> tuple[int, int]:
    """(width, height) of a PNG file, from its header."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


@pytest.mark.parametrize("num_iterations", [0, 1, 7])
def test_a_history_comes_back_from_its_npz_bytes(num_iterations):
    history = history_of(num_iterations)
    back = plotting.CurveHistory.from_npz(history.to_npz())
    for key in plotting.CURVE_KEYS:
        for got, want in zip(back.curve(key), history.curve(key), strict=True):
            np.testing.assert_array_equal(got, want)
        assert back.measured(key) == history.measured(key)


def test_the_helper_draws_the_curves_the_training_process_would(run_dir, tmp_path):
    history = history_of(5)
    painter = plot_process.CurvePainter.start()
    assert painter.process is not None
    asked, warnings = painter.draw(run_dir, history, "return", final=True)
    assert asked and not warnings and painter.pending == 1
    assert painter.close() == [] and painter.process is None
    here = plotting.plot_run(run_dir, tmp_path / "here.png", task_score_name="return", history=history)
    assert png_size(run_dir / layout.CURVES_FILE) == png_size(here)


def test_the_helpers_failures_are_warnings_and_it_goes_on(run_dir, tmp_path):
    painter = plot_process.CurvePainter.start()
    no_config = tmp_path / "no-config"
    no_config.mkdir()
    asked, warnings = painter.draw(no_config, history_of(3), None, final=True)  # RunConfig.load fails there
    assert asked and not warnings
    asked, warnings = painter.draw(run_dir, history_of(3), None, final=True)  # waits for the first one's reply
    assert asked and len(warnings) == 1 and warnings[0].startswith("warning: curves.png not updated (")
    assert "\n" not in warnings[0] and "Traceback" not in warnings[0]
    assert painter.close() == []
    assert png_size(run_dir / layout.CURVES_FILE)[0] > 0


def test_a_periodic_drawing_is_skipped_while_the_helper_draws(run_dir, monkeypatch):
    painter = plot_process.CurvePainter.start()
    try:
        # A helper that has not answered yet: nothing on its stdout for the first request.
        painter.pending = 1
        monkeypatch.setattr(painter, "_collect", lambda timeout_s: [])
        asked, warnings = painter.draw(run_dir, history_of(2), None, final=False)
        assert not asked and not warnings and painter.pending == 1
    finally:
        monkeypatch.undo()
        painter.pending = 0
        painter.close()


def test_where_the_helper_dies_the_drawings_go_on_here(run_dir):
    painter = plot_process.CurvePainter.start()
    painter.process.kill()
    painter.process.wait()
    asked, warnings = painter.draw(run_dir, history_of(4), None, final=True)
    assert asked and not warnings and painter.process is None  # drawn in this process
    assert png_size(run_dir / layout.CURVES_FILE)[0] > 0
    assert painter.close() == []


def test_a_helper_that_dies_owing_a_drawing_is_one_warning(run_dir):
    painter = plot_process.CurvePainter.start()
    asked, _ = painter.draw(run_dir, history_of(4), None, final=True)
    painter.process.kill()
    warnings = painter.close()
    # It died before or after answering: either the drawing was made or one warning says it was not.
    assert warnings in ([], ["warning: curves.png not updated (the plotting process exited)"])
    assert painter.process is None


def test_the_helper_serves_requests_until_its_input_ends(run_dir):
    """``serve`` itself, in this process: two requests, two replies, then the end of the stream."""
    good = plotting.CurveHistory.to_npz(history_of(3))
    requests = io.BytesIO()
    for directory in (run_dir, run_dir / "missing"):
        header = f'{{"run_dir": "{directory}", "task_score_name": null, "size": {len(good)}}}\n'
        requests.write(header.encode() + good)
    requests.seek(0)
    replies = io.StringIO()
    assert plot_process.serve(requests, replies) == 0
    lines = replies.getvalue().splitlines()
    assert lines[0] == "ok" and lines[1].startswith("error: ") and len(lines) == 2


def test_a_training_run_draws_its_curves_without_importing_matplotlib(tmp_path):
    """A command's run (inverted pendulum, 2 iterations, in a process of its own) leaves matplotlib
    to its helper process: ``curves.png`` exists once ``main`` has returned, and the training
    process never imported matplotlib."""
    run_dir = tmp_path / "run"
    script = f"""
import sys
from jaxpg.run.command import main
argv = ["--env", "inverted_pendulum", "--num-envs", "8", "--horizon", "32", "--eval-envs", "2",
        "--eval-horizon", "32", "--max-episode-steps", "50", "--iterations", "2", "--no-progress",
        "--run-dir", {str(run_dir)!r}]
status = main.main(argv)
print("status", status, "matplotlib", "matplotlib" in sys.modules)
"""
    root = Path(__file__).resolve().parent.parent
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=root, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.splitlines()[-1] == "status 0 matplotlib False"
    assert png_size(run_dir / layout.CURVES_FILE)[0] > 0
    assert "warning" not in proc.stderr
