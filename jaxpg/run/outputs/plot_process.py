"""``curves.png`` drawn by a helper process, so that matplotlib never runs in the training process.

Neither matplotlib's import nor a drawing (longer for long runs of many seeds)
then holds the training process's Python between its blocks, and the run's last drawing overlaps
its last checkpoint instead of following it. The training process starts the helper with its
callbacks, before the first block compiles; the helper imports matplotlib and draws a throwaway
figure (fonts, the Agg canvas) while the block compiles, on another core. Each ``draw`` sends the
curves (a ``plotting.CurveHistory``, as ``.npz`` bytes) down a pipe and returns at once; a
periodic drawing asked for while the last one is still being drawn is skipped (the next one shows
all). ``close`` waits for the last drawing. Where the helper cannot start, does not answer or dies,
the drawings happen in the training process (``plotting.plot_run``), as they did before.

    python -m jaxpg.run.outputs.plot_process    # the helper: a request on stdin, a reply line on stdout

A request is one JSON line, ``{"run_dir": ..., "task_score_name": ..., "size": N}``, then ``N``
bytes of ``.npz``; its reply is ``ok`` or ``error: WHAT``. The helper exits when its stdin closes
(so also when the training process is killed) and ignores SIGINT (Ctrl-C stops the training
process, which then closes the pipe after its last drawing).
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from jaxpg.run.outputs import plotting

CLOSE_TIMEOUT_S = 120.0
"""How long ``close`` waits for the last drawing (thousands of iterations of many seeds take a
few seconds) before it gives up on it with a warning."""


def _helper_environment() -> dict[str, str]:
    """This process's environment, with jaxpg's own directory first on ``PYTHONPATH`` (an
    uninstalled checkout imports it too) and matplotlib's file-only backend."""
    root = str(Path(__file__).resolve().parents[2])
    path = os.environ.get("PYTHONPATH", "")
    return os.environ | {"PYTHONPATH": root + (os.pathsep + path if path else ""), "MPLBACKEND": "Agg"}


class CurvePainter:
    """Draws a run's ``curves.png``: in a helper process (``start``) or, with ``process=None``,
    in this one. ``draw`` and ``close`` return warning lines (a plot must never stop training)."""

    def __init__(self, process: subprocess.Popen | None = None) -> None:
        self.process = process
        self.pending = 0  # requests sent and not yet answered
        self._replies = b""

    @classmethod
    def start(cls) -> CurvePainter:
        """A painter with its helper process started (in this process where that fails)."""
        if os.name != "posix" or not sys.executable:
            return cls()
        try:
            process = subprocess.Popen(
                [sys.executable, "-m", "jaxpg.run.outputs.plot_process"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                env=_helper_environment(),
                close_fds=True,
            )
        except OSError:
            return cls()
        return cls(process)

    def draw(
        self,
        run_dir: str | os.PathLike,
        history: plotting.CurveHistory | None,
        task_score_name: str | None,
        final: bool,
    ) -> tuple[bool, list[str]]:
        """Draw ``curves.png`` of ``run_dir`` from ``history`` (``None``: from its
        ``metrics.jsonl``, in this process): ``(asked, warnings)``. A drawing that is not ``final``
        is skipped (``asked`` False) while the helper draws an earlier one; a ``final`` one waits
        for it first."""
        warnings = self._collect(0.0)
        if self.process is not None and self.pending and final:
            warnings += self._collect(CLOSE_TIMEOUT_S)
        if self.process is not None and self.pending:
            if not final:
                return False, warnings
            warnings.append(self._give_up("did not answer"))  # owed a drawing: never empty
        if self.process is not None and history is not None:
            payload = history.to_npz()
            header = {"run_dir": str(run_dir), "task_score_name": task_score_name, "size": len(payload)}
            try:
                self.process.stdin.write(json.dumps(header).encode() + b"\n" + payload)
                self.process.stdin.flush()
                self.pending += 1
                return True, warnings
            except OSError:  # the helper died: draw here from now on
                self._give_up(None)
        try:
            plotting.plot_run(run_dir, task_score_name=task_score_name, history=history)
        except Exception as e:  # noqa: BLE001 - a plot must never stop training
            warnings.append(f"warning: curves.png not updated ({type(e).__name__}: {e})")
        return True, warnings

    def close(self, wait: bool = True) -> list[str]:
        """Let the helper finish its last drawing (unless ``wait`` is False) and exit; the
        warnings of the drawings not yet answered."""
        if self.process is None:
            return []
        warnings = self._collect(CLOSE_TIMEOUT_S if wait else 0.0)
        if self.pending:
            warnings.append(self._give_up("did not answer" if wait else None))
        else:
            self._give_up(None, kill=False)
        return [w for w in warnings if w]

    def _collect(self, timeout_s: float) -> list[str]:
        """Read the helper's replies for up to ``timeout_s`` seconds or until none is pending;
        the warning lines of its failed drawings. A helper that died is given up."""
        warnings: list[str] = []
        if self.process is None:
            return warnings
        deadline = time.monotonic() + timeout_s
        fd = self.process.stdout.fileno()
        while self.pending:
            ready, _, _ = select.select([fd], [], [], max(deadline - time.monotonic(), 0.0))
            if not ready:
                break
            chunk = os.read(fd, 65536)
            if not chunk:  # the helper exited, owing a drawing: the warning is never empty
                warnings.append(self._give_up("exited"))
                break
            self._replies += chunk
            while b"\n" in self._replies:
                line, self._replies = self._replies.split(b"\n", 1)
                self.pending -= 1
                reply = line.decode(errors="replace").strip()
                if reply != "ok":
                    warnings.append(f"warning: curves.png not updated ({reply.removeprefix('error: ')})")
        return warnings

    def _give_up(self, why: str | None, kill: bool = True) -> str:
        """Stop using the helper (later drawings happen in this process); the warning for the
        drawings it still owed (``why`` it did not draw them), or ``""``."""
        process, owed = self.process, self.pending
        self.process, self.pending = None, 0
        if process is not None:
            try:
                process.stdin.close()
            except OSError:
                pass
            if kill:
                process.kill()
            try:
                process.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                process.kill()
        if why is None or not owed:
            return ""
        return f"warning: curves.png not updated (the plotting process {why})"


def _warm_up() -> None:
    """Import matplotlib and draw a throwaway figure into memory: its fonts and canvas are ready
    before the first real drawing."""
    import io

    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [0, 1], label="warm-up")
    ax.legend()
    fig.tight_layout()
    fig.savefig(io.BytesIO(), format="png", dpi=30)
    plt.close(fig)


def serve(requests: Any, replies: Any) -> int:
    """Answer the requests of binary stream ``requests`` on text stream ``replies`` until the
    stream ends."""
    while True:
        header = requests.readline()
        if not header:
            return 0
        try:
            request = json.loads(header)
            history = plotting.CurveHistory.from_npz(requests.read(request["size"]))
            plotting.plot_run(request["run_dir"], task_score_name=request["task_score_name"], history=history)
            reply = "ok"
        except Exception as e:  # noqa: BLE001 - every failure is a reply, and the helper goes on
            reply = f"error: {type(e).__name__}: {e}"
        replies.write(" ".join(reply.split()) + "\n")
        replies.flush()


def main() -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        _warm_up()
    except Exception:  # noqa: BLE001, S110 - the first drawing reports what is wrong
        pass
    return serve(sys.stdin.buffer, sys.stdout)


if __name__ == "__main__":
    raise SystemExit(main())
