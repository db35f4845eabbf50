"""The small harness every benchmark script shares: timing, machine info, JSON results, a table.

- ``time_call(fn, *args, repeats=)`` and ``time_calls(call, repeats)``: the first call's seconds
  (compilation included) and the median of ``repeats`` later calls, each synchronised with
  ``jax.block_until_ready`` so that asynchronous dispatch does not hide device time;
- ``time_chained(fn, state, repeats)``: the median of synchronised calls ``state, out = fn(state)``,
  each continuing from the last (as a training loop chains them);
- ``time_for(call, seconds)``: how many synchronised calls fit in ``seconds``;
- ``time_back_to_back(fn, state, calls)``: seconds per call of ``calls`` calls dispatched back to
  back and synchronised once (as ``jaxpg.train`` dispatches its compiled calls);
- ``environment()``: the device, backend and the versions of Python, JAX, MuJoCo and jaxpg, and
  ``bytecode()``: whether the Python of MuJoCo, MJX and Warp was compiled to bytecode at install;
- ``write_json(path, rows, **meta)``: the rows with ``environment()`` and ``meta``;
- ``table(rows, columns)``: a Markdown table, and ``rate(x)``: ``1.23 M`` / ``45.6 k``;
- ``run_modes(script, modes, doc)``: the command line of a script with modes
  (``python benchmarks/NAME.py MODE [options]``);
- ``run_process(command, env, log)``: a training process as a user runs it, timed as a whole, its
  output lines stamped with their arrival; ``gymnasium_replay(run_dir, log)`` and
  ``gymnasium_score(log)``: its final mean policy scored in Gymnasium's own env, beside the next run.

The scripts are run from the repository root (``python benchmarks/NAME.py``) and import this
module as their sibling: Python puts a script's own directory first on ``sys.path``.
"""

from __future__ import annotations

import importlib.util
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any


def _sync(out: Any) -> Any:
    import jax

    return jax.block_until_ready(out)


def time_calls(call: Callable[[int], Any], repeats: int) -> tuple[float, float, Any]:
    """``(seconds of call(0), median seconds of call(1) ... call(repeats), output of call(0))``;
    ``call(i)`` is synchronised each time (``i`` lets a call take a fresh key)."""
    start = time.perf_counter()
    first_out = _sync(call(0))
    first = time.perf_counter() - start
    times = []
    for i in range(1, repeats + 1):
        start = time.perf_counter()
        _sync(call(i))
        times.append(time.perf_counter() - start)
    return first, statistics.median(times) if times else first, first_out


def time_call(fn: Callable, *args: Any, repeats: int) -> tuple[float, float, Any]:
    """``time_calls`` of ``fn(*args)``: compile seconds, median seconds, the last output."""
    out = []

    def call(i: int) -> Any:
        out.append(fn(*args))
        return out[-1]

    first, median, _ = time_calls(call, repeats)
    return first, median, out[-1]


def time_chained(fn: Callable, state: Any, repeats: int) -> tuple[float, tuple[Any, Any]]:
    """Median seconds of ``repeats`` synchronised calls ``state, out = fn(state)``, each on the last
    call's state; the caller has compiled and warmed ``fn``. Returns the last ``(state, out)``."""
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        state, out = _sync(fn(state))
        times.append(time.perf_counter() - start)
    return statistics.median(times), (state, out)


def time_back_to_back(fn: Callable, state: Any, calls: int) -> tuple[float, float, Any]:
    """``(seconds of the first call, seconds per call after a warm-up, state)`` for ``state =
    fn(state)[0]`` dispatched ``calls`` times back to back and synchronised once."""
    start = time.perf_counter()
    state = _sync(fn(state))[0]
    first = time.perf_counter() - start
    state = _sync(fn(state))[0]
    start = time.perf_counter()
    for _ in range(calls):
        state = fn(state)[0]
    _sync(state)
    return first, (time.perf_counter() - start) / max(calls, 1), state


def time_for(call: Callable[[], Any], seconds: float) -> tuple[float, int]:
    """``(elapsed seconds, calls)``: ``call()`` synchronised and repeated until ``seconds`` have
    passed, after one warm-up call (for paths whose calls vary in length, e.g. host emulators)."""
    _sync(call())
    start, calls = time.perf_counter(), 0
    while time.perf_counter() - start < seconds:
        _sync(call())
        calls += 1
    return time.perf_counter() - start, calls


def _version(package: str) -> str | None:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return None


def environment() -> dict[str, Any]:
    """What a result was measured on: device kind and count, backend, host, library versions."""
    import jax

    device = jax.devices()[0]
    return {
        "device": device.device_kind,
        "device_count": jax.device_count(),
        "backend": jax.default_backend(),
        "host": platform.node(),
        "python": platform.python_version(),
        **{name: _version(name) for name in ("jax", "jaxlib", "mujoco", "mujoco-mjx", "warp-lang", "jaxpg")},
        "bytecode": bytecode(),
    }


BYTECODE_PACKAGES = ("mujoco.mjx", "warp")
"""The packages whose import dominates a run's start (``import mujoco.mjx`` imports Warp's)."""


def bytecode(packages: Sequence[str] = BYTECODE_PACKAGES) -> dict[str, Any]:
    """Whether each package's ``__init__.py`` has its compiled bytecode beside it (``None``: not
    installed), and whether this Python writes bytecode (``PYTHONDONTWRITEBYTECODE`` unset).

    Both matter to a timed start: a package installed with ``pip install --no-compile`` has none,
    and where Python writes none either, every process compiles its sources again (about 0.8 s of
    ``import mujoco.mjx`` on a 2-core CPU, ``benchmarks/results/2026-12-05-cpu-bytecode/``). A
    plain ``pip install`` compiles them. Nothing is imported: the packages are located on
    ``sys.path``."""
    compiled: dict[str, bool | None] = {}
    for name in packages:
        top, *rest = name.split(".")
        spec = importlib.util.find_spec(top)
        if spec is None or not spec.submodule_search_locations:
            compiled[name] = None
            continue
        init = Path(next(iter(spec.submodule_search_locations)), *rest, "__init__.py")
        compiled[name] = Path(importlib.util.cache_from_source(str(init))).exists() if init.exists() else None
    return {"compiled": compiled, "writes_bytecode": not sys.dont_write_bytecode}


def bytecode_note(state: dict[str, Any]) -> str | None:
    """One line when a timed process will compile installed packages' sources (``bytecode()``'s
    ``state``): the packages without bytecode, and whether each process pays or the first alone."""
    missing = [name for name, done in state["compiled"].items() if done is False]
    if not missing:
        return None
    who = (
        "the first process compiles them and writes the bytecode"
        if state["writes_bytecode"]
        else "PYTHONDONTWRITEBYTECODE is set, so every process compiles them again"
    )
    return (
        f"note: {', '.join(missing)} have no compiled bytecode (installed with --no-compile?): {who}; "
        "`python -m compileall` on their site-packages does what pip install does by default"
    )


def describe() -> str:
    """One line: ``device (backend), N devices, jax X, mujoco Y``."""
    env = environment()
    return (
        f"{env['device']} ({env['backend']}), {env['device_count']} device(s), jax {env['jax']}, mujoco {env['mujoco']}"
    )


def write_json(path: str | Path | None, rows: Any, **meta: Any) -> None:
    """Writes ``{"environment": ..., "meta": meta, "rows": rows}`` to ``path`` (nothing if None)."""
    if not path:
        return
    Path(path).write_text(json.dumps({"environment": environment(), "meta": meta, "rows": rows}, indent=1))
    print(f"wrote {path}", flush=True)


def rows_of(path: str | Path) -> list[dict[str, Any]]:
    """The rows of a file ``write_json`` wrote (or of an older plain list of rows)."""
    data = json.loads(Path(path).read_text())
    return data["rows"] if isinstance(data, dict) and "rows" in data else data


def rate(x: float) -> str:
    """``1.23 M``, ``45.6 k`` or ``789``."""
    return f"{x / 1e6:.2f} M" if x >= 1e6 else f"{x / 1e3:.1f} k" if x >= 1e3 else f"{x:.0f}"


def table(rows: Sequence[Any], columns: Sequence[tuple[str, Callable[[Any], Any]]]) -> str:
    """A Markdown table: one column per ``(header, cell(row))``."""
    lines = ["| " + " | ".join(h for h, _ in columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(str(cell(r)) for _, cell in columns) + " |" for r in rows]
    return "\n".join(lines)


def run_modes(
    script: str, modes: dict[str, Callable[[list[str]], Any]], doc: str | None, argv: Sequence[str] | None = None
) -> None:
    """``python benchmarks/NAME.py MODE [options]``: ``modes[MODE](options)``, where ``argv``
    (default ``sys.argv[1:]``) is ``[MODE, *options]``. Without a known mode: the script's ``doc``
    and a usage line naming the modes, exit status 1. ``script``: the script's ``__file__``."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv or argv[0] not in modes:
        print(doc)
        raise SystemExit(f"usage: python benchmarks/{Path(script).name} {{{','.join(modes)}}} [options]")
    modes[argv[0]](argv[1:])


ROOT = Path(__file__).resolve().parent.parent


def run_process(command: Sequence[str], env: dict[str, str], log: Path) -> tuple[int, float, list[tuple[float, str]]]:
    """Run ``command`` from the repository root with environment ``env`` (added to this process's),
    its output written to ``log``; returns the exit status, the wall clock of the whole process in
    seconds and each output line with the seconds since the start at which it arrived."""
    start = time.perf_counter()
    stamped = []
    full_env = {**os.environ, "PYTHONUNBUFFERED": "1", **env}
    with log.open("w") as out:
        process = subprocess.Popen(
            list(command), cwd=ROOT, env=full_env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
        for line in process.stdout:
            stamped.append((time.perf_counter() - start, line.rstrip("\n")))
            out.write(line)
        status = process.wait()
    return status, time.perf_counter() - start, stamped


def gymnasium_replay(run_dir: Path, log: Path, episodes: int = 10, train_seed: int | None = None) -> subprocess.Popen:
    """``python -m jaxpg.evaluate RUN --gymnasium --episodes N [--train-seed S]`` in the
    background, on the CPU (so that it runs beside the next training process without touching the
    GPU)."""
    command = [sys.executable, "-m", "jaxpg.evaluate", str(run_dir), "--gymnasium", "--episodes", str(episodes)]
    command += [] if train_seed is None else ["--train-seed", str(train_seed)]
    env = {**os.environ, "JAX_PLATFORMS": "cpu", "JAXPG_COMPILATION_CACHE": "off"}
    return subprocess.Popen(command, cwd=ROOT, env=env, stdout=log.open("w"), stderr=subprocess.STDOUT)


def gymnasium_score(log: Path) -> tuple[float | None, float | None]:
    """Mean and standard deviation of the returns that ``jaxpg.evaluate`` printed (``None`` if none)."""
    match = re.search(r"^return: ([-\d.]+) ± ([\d.]+)", log.read_text(), re.M)
    return (float(match.group(1)), float(match.group(2))) if match else (None, None)


def metrics_rows(run_dir: Path) -> list[dict[str, Any]]:
    """The rows of a run directory's ``metrics.jsonl`` (``[]`` when there is none)."""
    path = Path(run_dir) / "metrics.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.exists() else []
