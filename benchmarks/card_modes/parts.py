"""``card_command.py parts``: the card's command in this process, its programs' tracing, lowering and compilation."""

from __future__ import annotations

import argparse
import atexit
import logging
import re
import runpy
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from typing import Any

import harness

from card_modes import CARD_COMMAND, ROOT

RAW = argparse.RawDescriptionHelpFormatter

PARTS_DOC = """The card's command, ``python experiments/hopper.py --num-envs 256``, run inside this process with
two clocks that a whole-process timing (``card_command.py card``) cannot see:

- **JAX's work on each program before it runs**, from JAX's own compile log (``jax_log_compiles``):
  tracing, lowering to MLIR, and XLA's compilation or its load from the persistent cache (a cache
  hit is named). A warm run's "programs loaded" (the first block's ``compiled in`` line) is these
  for the training block and the evaluation, which MuJoCo Warp's runs prepare on two threads
  before the first block: their times overlap, so the line is less than their sum;
- **the Python time of MuJoCo Warp's FFI callbacks**: MJX calls each of MuJoCo Warp's kernels
  through an XLA FFI target whose handler is a Python function (Warp's ``ffi_callback``), run
  under the GIL at every call; on a GPU it launches a captured CUDA graph, on a CPU it runs the
  kernels themselves. Each call is timed, counted by target, the first call of each target (a
  graph capture on a GPU) apart from the rest.

    python benchmarks/card_command.py parts --json parts.json          # the card, as typed
    python benchmarks/card_command.py parts -- --iterations 10 --impl warp   # on a CPU, shorter

Flags after ``--`` are added to the card's command. Run it after a first run filled the caches
(``JAXPG_COMPILATION_CACHE``, ``WARP_CACHE_PATH``) to see a warm run. The training's output is
printed as usual; the tables follow it.
"""
# JAX's compile log: "Finished tracing + transforming NAME for pjit in S sec" (wording varies by
# version), "Finished jaxpr to MLIR module conversion jit(NAME) in S sec", "Finished XLA
# compilation of jit(NAME) in S sec", and "Persistent compilation cache hit for 'jit_NAME'".
_STAGES = (
    ("tracing", re.compile(r"tracing")),
    ("lowering", re.compile(r"MLIR")),
    ("compile", re.compile(r"XLA compilation")),
)
_SECONDS = re.compile(r" in ([0-9.eE+-]+) sec")
_NAME = re.compile(r"jit\(([^)]*)\)|tracing(?: \+ transforming)? (\S+) for")
_CACHE_HIT = re.compile(r"[Pp]ersistent compilation cache hit for 'jit_([^']+)'")


class CompileLog(logging.Handler):
    """Collects JAX's compile-log lines: ``stages[name][stage]`` seconds (summed over repeats) and
    the names whose program came from the persistent cache."""

    def __init__(self) -> None:
        super().__init__(level=logging.DEBUG)
        self.stages: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
        self.cache_hits: set[str] = set()

    def emit(self, record: logging.LogRecord) -> None:
        parse_line(record.getMessage(), self.stages, self.cache_hits)


def parse_line(message: str, stages: dict[str, dict[str, float]], cache_hits: set[str]) -> None:
    """Add one compile-log line to ``stages`` (``name -> stage -> seconds``) or ``cache_hits``."""
    if (hit := _CACHE_HIT.search(message)) is not None:
        cache_hits.add(plain_name(hit.group(1)))
        return
    seconds, name = _SECONDS.search(message), _NAME.search(message)
    if not message.startswith("Finished") or seconds is None or name is None:
        return
    for stage, pattern in _STAGES:
        if pattern.search(message):
            stages[name.group(1) or name.group(2)][stage] += float(seconds.group(1))
            return


def plain_name(name: str) -> str:
    """A program's name as both log lines can be matched on: ``<lambda>`` and the cache's
    ``_lambda`` are both ``lambda``."""
    return re.sub(r"[^0-9A-Za-z_]", "", name).strip("_")


class CallbackClock:
    """Wraps FFI handlers ``handler(call_frame, platform)`` to time every call, by target name."""

    def __init__(self) -> None:
        self.calls: dict[str, list[float]] = defaultdict(list)

    def wrap(self, name: str, handler: Callable[..., Any]) -> Callable[..., Any]:
        """``handler`` with each call's seconds appended to ``calls[name]``; its result unchanged."""

        def timed(*args: Any) -> Any:
            start = time.perf_counter()
            try:
                return handler(*args)
            finally:
                self.calls[name].append(time.perf_counter() - start)

        return timed

    def summary(self) -> dict[str, Any]:
        """Calls, seconds in all, seconds of each target's first call (on a GPU: its graph capture)
        and the median microseconds of the later calls."""
        later = [s for seconds in self.calls.values() for s in seconds[1:]]
        return {
            "targets": len(self.calls),
            "calls": sum(len(s) for s in self.calls.values()),
            "seconds": sum(sum(s) for s in self.calls.values()),
            "first_calls_s": sum(s[0] for s in self.calls.values() if s),
            "later_calls_s": sum(later),
            "later_median_us": statistics.median(later) * 1e6 if later else None,
        }


def time_warp_callbacks(clock: CallbackClock) -> str | None:
    """Route every FFI target Warp registers from now on through ``clock``; a note if this Warp
    has no such hook (then its callbacks are not timed)."""
    try:
        from warp._src.jax import ffi
    except ImportError as e:
        return f"MuJoCo Warp's callbacks not timed: {e}"
    register = getattr(ffi, "_register_ffi_targets", None)
    if register is None:
        return "MuJoCo Warp's callbacks not timed: this Warp has no _register_ffi_targets"

    def register_timed(name: str, callback: Callable[..., Any]) -> Any:
        return register(name, clock.wrap(name, callback))

    ffi._register_ffi_targets = register_timed
    return None


def report(log: CompileLog, clock: CallbackClock, wall_s: float, note: str | None, json_path: str | None) -> None:
    """Print the two tables and write the JSON."""
    programs = sorted(log.stages, key=lambda n: -sum(log.stages[n].values()))
    rows = [
        {
            "program": n,
            **{s: log.stages[n].get(s, 0.0) for s, _ in _STAGES},
            "cache_hit": plain_name(n) in log.cache_hits,
        }
        for n in programs
    ]
    big = [r for r in rows if r["tracing"] + r["lowering"] + r["compile"] >= 0.05]
    small = [r for r in rows if r not in big]
    others = [{"program": f"{len(small)} others", **{s: sum(r[s] for r in small) for s, _ in _STAGES}}] if small else []
    print(f"\nJAX's work before each program runs (s), {harness.describe()}:")
    print(
        harness.table(
            big + others,
            [
                ("program", lambda r: r["program"]),
                ("tracing", lambda r: f"{r['tracing']:.2f}"),
                ("lowering", lambda r: f"{r['lowering']:.2f}"),
                ("compile or cache load", lambda r: f"{r['compile']:.2f}"),
                ("from the cache", lambda r: {True: "yes", False: "no"}.get(r.get("cache_hit"), "-")),
            ],
        )
    )
    summary = clock.summary()
    print(f"\nMuJoCo Warp's FFI callbacks (Python, under the GIL), whole process {wall_s:.1f} s:")
    if note is not None:
        print(note)
    else:
        median = summary["later_median_us"]
        print(
            harness.table(
                [summary],
                [
                    ("targets", lambda r: r["targets"]),
                    ("calls", lambda r: f"{r['calls']:,}"),
                    ("seconds in all", lambda r: f"{r['seconds']:.2f}"),
                    ("first call of each target (s)", lambda r: f"{r['first_calls_s']:.2f}"),
                    ("later calls (s)", lambda r: f"{r['later_calls_s']:.2f}"),
                    ("later calls, median us", lambda r: "-" if median is None else f"{median:.0f}"),
                ],
            )
        )
    harness.write_json(json_path, {"programs": rows, "warp_callbacks": summary, "wall_s": wall_s, "note": note})


def parts_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="card_command.py parts", description=PARTS_DOC, formatter_class=RAW)
    parser.add_argument("--json", default=None)
    parser.add_argument("--run-dir", default=None, help="the run's directory (default: a new temporary one)")
    parser.add_argument("extra", nargs="*", help="after --: flags added to the card's command")
    args = parser.parse_args(argv)

    clock, log = CallbackClock(), CompileLog()
    note = time_warp_callbacks(clock)  # before MJX registers its targets
    import jax

    jax.config.update("jax_log_compiles", True)
    jax_logger = logging.getLogger("jax")
    jax_logger.addHandler(log)
    jax_logger.propagate = False  # the log goes to the tables, not to the terminal
    start = time.perf_counter()
    atexit.register(lambda: report(log, clock, time.perf_counter() - start, note, args.json))
    run_dir = args.run_dir or tempfile.mkdtemp(prefix="card-parts-")
    sys.argv = [str(ROOT / CARD_COMMAND[0]), *CARD_COMMAND[1:], "--run-dir", run_dir, *args.extra]
    runpy.run_path(sys.argv[0], run_name="__main__")  # ends the process, after the atexit handlers
