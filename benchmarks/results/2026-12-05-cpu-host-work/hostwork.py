"""The card's command with each host callback timed: every callable of
``jaxpg.run.callbacks.host_callbacks`` and ``Checkpoints.plot`` wrapped in a timer, the totals
printed to stderr at exit (``HOST name: total ... over N blocks; >20 ms: [(first iteration, s)]``).

    python benchmarks/results/2026-12-05-cpu-host-work/hostwork.py --num-envs 16 --impl jax --run-dir DIR

With ``FIRST_PLOT_AT_ONCE=1`` in the environment, ``curves.png`` is first drawn at the first
checkpoint, as before 2026-12-05, instead of ``PLOT_EVERY_S`` after the start.
"""

from __future__ import annotations

import atexit
import collections
import math
import os
import runpy
import sys
import time
from typing import Any

import jaxpg.run.session as session
from jaxpg.run import callbacks

seconds: dict[str, list[tuple[int, float]]] = collections.defaultdict(list)
make_callbacks = session.host_callbacks
draw = callbacks.Checkpoints.plot


def timed(name: str, callback: Any) -> Any:
    """``callback`` with each call's duration appended to ``seconds[name]``."""

    def call(ts: Any, metrics: Any, first: int) -> None:
        start = time.perf_counter()
        callback(ts, metrics, first)
        seconds[name].append((first, time.perf_counter() - start))

    return call


def timed_host_callbacks(*args: Any, **kwargs: Any) -> Any:
    host = make_callbacks(*args, **kwargs)
    host.callables[:] = [timed(getattr(c, "__name__", type(c).__name__), c) for c in host.callables]
    if os.environ.get("FIRST_PLOT_AT_ONCE"):  # the behaviour before 2026-12-05: drawn at the first checkpoint
        host.checkpoints.last_plot = -math.inf
    return host


def timed_plot(self: Any, step: int) -> None:
    start = time.perf_counter()
    draw(self, step)
    seconds["plot"].append((step, time.perf_counter() - start))


def report() -> None:
    for name, calls in seconds.items():
        slow = [(first, round(s, 3)) for first, s in calls if s > 0.02]
        total = sum(s for _, s in calls)
        print(f"HOST {name}: total {total:.3f} s over {len(calls)} blocks; >20 ms: {slow}", file=sys.stderr)


session.host_callbacks = timed_host_callbacks
callbacks.Checkpoints.plot = timed_plot
atexit.register(report)
sys.argv = ["experiments/hopper.py", *sys.argv[1:]]
runpy.run_path("experiments/hopper.py", run_name="__main__")
