"""Latency of one MuJoCo Warp physics step at small and large batches, per CUDA-graph setting.

For each task and env count of the plan, each Warp graph mode and each XLA command-buffer setting,
times a ``lax.scan`` of ``--steps`` env steps of ``jit(vmap(task.physics_step))`` (the physics
alone: ``frame_skip`` ``mjx.step`` calls per env step, uniform random actions drawn in the scan),
after compilation, as the median of ``--repeats`` chained calls. Printed: ms per physics step
(a call's seconds / (steps x frame_skip)), ms per env step and env steps/s (envs x steps / seconds).

The two settings:

  graph mode       ``mjx.put_model(..., graph_mode=warp.JaxCallableGraphMode.X)``, which MJX keeps
                   in ``model.opt._impl.graph_mode`` and hands to every Warp callable it registers
                   (jaxpg: ``make_task(..., warp_graph_mode="X")``). ``NONE``: no capture (Warp's
                   solver then reads its loop condition back to the host every iteration); ``JAX``:
                   the callable is marked command-buffer compatible, so XLA may record it in its own
                   CUDA graph; ``WARP``: Warp captures a graph per set of buffer addresses (MJX's GPU
                   default); ``WARP_STAGED`` / ``WARP_STAGED_EX``: one graph on staging buffers,
                   copies inside / outside the graph. On the CPU only ``NONE`` and ``JAX`` run.
  command buffers  XLA's ``--xla_gpu_enable_command_buffer``, process-wide, so each setting runs in
                   child processes of its own: ``default`` (flag unset: XLA's own list, which
                   jaxpg runs with), ``off`` (the empty list) or ``on`` (``ON_COMMANDS``: the
                   default plus loops and conditionals). A value already in ``XLA_FLAGS`` is kept.

The parent starts no JAX backend: it runs one child per setting for the first (task, envs) of the
plan, then one per setting for the rest, and prints each row as it arrives. A child that dies or
spends over ``--row-timeout`` seconds on a row is killed; its row records why and a fresh child
takes the next. After ``--budget`` seconds nothing more runs. ``--json`` is rewritten after each
child, so a run cut short keeps what finished. The default ``--budget`` bounds a run of the default
plan (the first child also compiles Warp's kernels, which later children load from Warp's cache). ``--profile DIR``
runs one setting (the first of each list) and writes a ``jax.profiler`` trace of one call, with a
summary: kernels per physics step, the GPU's busy share and the gaps between kernels (open
``DIR/**/*.trace.json.gz`` in https://ui.perfetto.dev).

    python benchmarks/step_latency.py --json latency.json
    python benchmarks/step_latency.py --tasks hopper --envs 256 --modes WARP JAX --command-buffers off on
    python benchmarks/step_latency.py --tasks hopper --envs 256 --modes WARP --steps 10 --profile /tmp/lat
    python benchmarks/step_latency.py --quick          # tiny CPU run: Hopper, 2 envs, mode NONE
"""

from __future__ import annotations

import argparse
import gzip
import importlib.util
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import harness

GRAPH_MODES = ("WARP", "NONE", "JAX", "WARP_STAGED", "WARP_STAGED_EX")
"""``warp.JaxCallableGraphMode`` members, MJX's GPU default first."""
CPU_GRAPH_MODES = ("NONE", "JAX")
"""The modes Warp runs on the CPU (the others need CUDA)."""
COMMAND_BUFFER_FLAG = "xla_gpu_enable_command_buffer"
ON_COMMANDS = "+WHILE,+CONDITIONAL"
"""Command buffers ``on``: XLA's default command types (fusions, cuBLAS, cuDNN, custom calls such as
Warp's, dynamic-slice fusions) plus loops and conditionals, so that a whole ``lax.scan`` may be one."""
COMMAND_BUFFERS = {"off": "", "default": None, "on": ON_COMMANDS}
"""Setting -> value of ``--xla_gpu_enable_command_buffer`` (``None``: left unset)."""
DEFAULT_PLAN = (("hopper", 256), ("hopper", 16), ("hopper", 4096), ("ant", 256), ("humanoid", 256))
"""(task, envs) run when neither ``--tasks`` nor ``--envs`` is given, the most wanted first."""
QUICK_PLAN = (("hopper", 2),)


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line, checked; ``--quick`` fills in a tiny plan (options given still win)."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", nargs="+", help="tasks (default: the plan, DEFAULT_PLAN)")
    parser.add_argument("--envs", nargs="+", type=int, help="env counts (default: the plan)")
    parser.add_argument("--modes", nargs="+", type=str.upper, choices=GRAPH_MODES, help="Warp graph modes")
    parser.add_argument("--command-buffers", nargs="+", choices=tuple(COMMAND_BUFFERS), help="default: default off on")
    parser.add_argument("--steps", type=int, help="env steps per timed call (K; default 100)")
    parser.add_argument("--repeats", type=int, help="timed calls per row, median taken (default 5)")
    parser.add_argument("--row-timeout", type=float, default=150.0, help="seconds a child may spend on one row")
    parser.add_argument("--budget", type=float, default=300.0, help="seconds after which the parent stops")
    parser.add_argument("--profile", metavar="DIR", help="trace one call of the first setting into DIR")
    parser.add_argument("--json", metavar="PATH", help="write the rows here (rewritten after each child)")
    parser.add_argument("--quick", action="store_true", help="tiny plan for the CPU: hopper, 2 envs, NONE")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--items", nargs="+", default=[], help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    quick = args.quick
    args.modes = args.modes or (["NONE"] if quick else list(GRAPH_MODES))
    args.command_buffers = args.command_buffers or (["off"] if quick else ["default", "off", "on"])
    args.steps = args.steps or (2 if quick else 100)
    args.repeats = args.repeats or (1 if quick else 5)
    args.pairs = plan(args.tasks, args.envs, QUICK_PLAN if quick else DEFAULT_PLAN)
    args.items = [(mode, task, int(n)) for mode, task, n in (item.split(":") for item in args.items)]
    bad = [n for _, n in args.pairs if n < 1] + [x for x in (args.steps, args.repeats) if x < 1]
    if bad:
        parser.error(f"env counts, --steps and --repeats must be positive, got {bad[0]}")
    if args.json and not Path(args.json).resolve().parent.is_dir():
        parser.error(f"--json {args.json}: no such directory")
    return args


def plan(tasks: Sequence[str] | None, env_counts: Sequence[int] | None, default: Sequence[tuple[str, int]]) -> list:
    """``[(task, envs), ...]``: every task of ``tasks`` with every count of ``env_counts``; a list not
    given takes the values ``default`` has (``default`` itself when neither is given)."""
    if tasks is None and env_counts is None:
        return list(default)
    tasks = tasks or list(dict.fromkeys(t for t, _ in default))
    env_counts = env_counts or list(dict.fromkeys(n for _, n in default))
    return [(task, n) for task in tasks for n in env_counts]


def work(pairs: Sequence[tuple[str, int]], modes: Sequence[str], settings: Sequence[str]) -> list:
    """``[(setting, mode, task, envs), ...]`` in the order run: the first pair under every setting
    and mode, then the other pairs; consecutive items of one setting share a child process."""
    order = [pairs[:1], pairs[1:]]
    return [(cb, mode, task, n) for part in order for cb in settings for mode in modes for task, n in part]


def xla_flags(setting: str, current: str, profiling: bool = False) -> str:
    """``XLA_FLAGS`` for command-buffer ``setting`` on top of ``current`` (a flag already there is
    kept); while profiling, XLA is asked to keep command buffers, which it otherwise drops."""
    from jaxpg.xla_flags import with_option

    value = COMMAND_BUFFERS[setting]
    flags = current if value is None else with_option(current, COMMAND_BUFFER_FLAG, value)
    if profiling and value != "":
        flags = with_option(flags, "xla_enable_command_buffers_during_profiling", "true")
    return flags


def figures(call_s: float, steps: int, envs: int, frame_skip: int) -> dict[str, float]:
    """A row's rates from the median seconds ``call_s`` of one call of ``steps`` env steps of ``envs``
    envs, each ``frame_skip`` physics steps."""
    return {
        "ms_per_physics_step": 1e3 * call_s / (steps * frame_skip),
        "ms_per_env_step": 1e3 * call_s / steps,
        "env_steps_per_s": envs * steps / call_s,
    }


# ----------------------------------------------------------------------------- in the child


def stepper(task: Any, envs: int, steps: int) -> tuple[Any, Any]:
    """``(init(key) -> carry, run(carry) -> carry)``: ``run`` is ``steps`` env steps of ``envs``
    envs (``task.physics_step`` under ``vmap``) in one ``lax.scan``, uniform random actions."""
    import jax

    def init(key: jax.Array) -> tuple[Any, jax.Array]:
        return jax.vmap(lambda k: task.reset(k).data)(jax.random.split(key, envs)), key

    def run(carry: tuple[Any, jax.Array]) -> tuple[Any, jax.Array]:
        def body(carry: tuple[Any, jax.Array], _: None) -> tuple[tuple[Any, jax.Array], None]:
            data, key = carry
            key, draw = jax.random.split(key)
            shape = (envs, task.action_size)
            actions = jax.random.uniform(draw, shape, minval=task.action_low, maxval=task.action_high)
            return (jax.vmap(task.physics_step)(data, actions), key), None

        return jax.lax.scan(body, carry, None, length=steps)[0]

    return jax.jit(init), jax.jit(run)


def measure(name: str, envs: int, mode: str, args: argparse.Namespace) -> tuple[dict[str, Any], Any, Any]:
    """One row (compile seconds, median call seconds and ``figures``), the compiled call and its
    carry after timing."""
    import jax
    import jax.numpy as jnp

    from jaxpg import envs as envs_lib

    kwargs = {"fidelity": "fast", "impl": "warp", "warp_graph_mode": mode}
    task = envs_lib.make_task(name, **kwargs, **envs_lib.warp_capacity(name, kwargs, envs))
    init, run = stepper(task, envs, args.steps)
    carry = jax.block_until_ready(init(jax.random.key(0)))
    start = time.perf_counter()
    compiled = run.lower(carry).compile()
    compile_s = time.perf_counter() - start
    for _ in range(2):  # warm-up: Warp loads its modules and captures graphs for both carries' buffers
        carry = jax.block_until_ready(compiled(carry))
    call_s, (carry, _) = harness.time_chained(lambda c: (compiled(c), None), carry, args.repeats)
    finite = all(bool(jnp.all(jnp.isfinite(x))) for x in jax.tree.leaves(carry[0]) if x.dtype.kind == "f")
    row = {"compile_s": compile_s, "call_s": call_s, "frame_skip": task.frame_skip, "finite": finite}
    return {**row, **figures(call_s, args.steps, envs, task.frame_skip)}, compiled, carry


def child_main(args: argparse.Namespace) -> None:
    """Measure each ``--items`` (mode, task, envs) in this process, under this process's command-buffer
    setting; one ``ROW {json}`` line each, in order (a failing item gives a row with its error)."""
    import jax

    if importlib.util.find_spec("warp"):  # else make_task says what is missing, in each row
        importlib.import_module("warp").config.quiet = True  # no line per kernel module
    print("ENV " + json.dumps(harness.environment()), flush=True)
    for mode, name, envs in args.items:
        row = {
            "task": name,
            "envs": envs,
            "mode": mode,
            "command_buffers": args.command_buffers[0],
            "steps": args.steps,
        }
        if jax.default_backend() != "gpu" and mode not in CPU_GRAPH_MODES:
            print("ROW " + json.dumps({**row, "error": f"graph mode {mode} needs a CUDA GPU"}), flush=True)
            continue
        try:
            result, compiled, carry = measure(name, envs, mode, args)
        except Exception as error:  # one failing setting (e.g. a mode Warp rejects) ends its row only
            print("ROW " + json.dumps({**row, "error": f"{type(error).__name__}: {error}"[:400]}), flush=True)
            continue
        if args.profile:
            result["profile"] = profile(compiled, carry, Path(args.profile), args.steps * result["frame_skip"])
        print("ROW " + json.dumps({**row, **result}), flush=True)


def profile(compiled: Any, carry: Any, out: Path, physics_steps: int) -> dict[str, Any]:
    """Trace one call of ``compiled`` into ``out``: the trace's file, its wall time, ``trace_summary``."""
    import jax

    with jax.profiler.trace(str(out), create_perfetto_trace=True):
        start = time.perf_counter()
        jax.block_until_ready(compiled(carry))
        wall_s = time.perf_counter() - start
    traces = sorted(out.rglob("*.trace.json.gz"), key=lambda p: p.stat().st_mtime)
    if not traces:
        return {"wall_ms": 1e3 * wall_s, "note": f"no Perfetto trace under {out}: open its xplane.pb in TensorBoard"}
    with gzip.open(traces[-1], "rt") as f:
        return {"trace": str(traces[-1]), "wall_ms": 1e3 * wall_s, **trace_summary(json.load(f), physics_steps)}


def trace_summary(trace: dict, physics_steps: int) -> dict[str, Any]:
    """Of a Perfetto trace: GPU events (kernels and copies) and copies per physics step, the GPU span,
    its busy share and the gaps between one event's end and the next one's start on each stream
    (median and total, in us). Host callbacks and launches are on the host threads of the trace."""
    from profile_trace import busy_union, device_kernels

    kernels = device_kernels(trace)
    if not kernels:
        return {"kernels": 0, "note": "no GPU events in the trace (a CPU run, or CUPTI was unavailable)"}
    by_stream: dict[Any, list[tuple[float, float]]] = {}
    for event in kernels:
        by_stream.setdefault((event["pid"], event.get("tid")), []).append((event["ts"], event["ts"] + event["dur"]))
    gaps = []
    for intervals in by_stream.values():
        intervals.sort()
        gaps += [max(0.0, nxt[0] - prev[1]) for prev, nxt in zip(intervals, intervals[1:], strict=False)]
    span = max(e["ts"] + e["dur"] for e in kernels) - min(e["ts"] for e in kernels)
    busy = busy_union([(e["ts"], e["ts"] + e["dur"]) for e in kernels])
    return {
        "kernels": len(kernels),
        "kernels_per_physics_step": len(kernels) / physics_steps,
        "copies_per_physics_step": sum("memcpy" in e["name"].lower() for e in kernels) / physics_steps,
        "span_us_per_physics_step": span / physics_steps,
        "busy_share": busy / span if span else 0.0,
        "median_gap_us": statistics.median(gaps) if gaps else 0.0,
        "gap_us_per_physics_step": sum(gaps) / physics_steps,
        "streams": len(by_stream),
    }


# ---------------------------------------------------------------------------- in the parent


def child_command(args: argparse.Namespace, setting: str, items: Sequence[tuple[str, str, str, int]]) -> list[str]:
    """The command line of a child that measures ``items`` ``(setting, mode, task, envs)``."""
    command = [sys.executable, str(Path(__file__).resolve()), "--child", "--command-buffers", setting]
    command += ["--steps", str(args.steps), "--repeats", str(args.repeats)]
    command += ["--items", *(f"{mode}:{task}:{n}" for _, mode, task, n in items)]
    return command + (["--profile", args.profile] if args.profile else [])


def run_child(command: list[str], env: dict[str, str], row_timeout: float, deadline: float) -> tuple:
    """Run one child, echoing its rows as they arrive; ``(rows, environment, how it ended)``. The
    child is killed when a row takes over ``row_timeout`` seconds or at ``time.perf_counter()`` =
    ``deadline``; the rows it printed until then are kept."""
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, text=True, cwd=harness.ROOT)
    last_row, why = [time.perf_counter()], []

    def watch() -> None:
        while process.poll() is None:
            now = time.perf_counter()
            if now - last_row[0] > row_timeout or now > deadline:
                why.append(f"no row within {row_timeout:.0f} s" if now <= deadline else "the budget ran out")
                process.kill()
                return
            time.sleep(0.5)

    threading.Thread(target=watch, daemon=True).start()
    rows, environment = [], None
    for line in process.stdout:
        tag, _, payload = line.partition(" ")
        if tag == "ROW":
            rows.append(json.loads(payload))
            last_row[0] = time.perf_counter()
            print(progress_line(rows[-1]), flush=True)
        elif tag == "ENV":
            environment = json.loads(payload)
        else:
            print("  | " + line.rstrip(), flush=True)
    status = process.wait()
    return rows, environment, why[0] if why else "ok" if status == 0 else f"exit status {status}"


def progress_line(row: dict[str, Any]) -> str:
    """One line per finished row."""
    head = f"{row['task']:>9} {row['envs']:>5} envs  {row['mode']:<14} cb {row['command_buffers']:<7}"
    if "error" in row:
        return f"{head} error: {row['error']}"
    return (
        f"{head} {row['ms_per_physics_step']:.4f} ms/physics step  {harness.rate(row['env_steps_per_s'])} env steps/s"
        f"  (compile {row['compile_s']:.1f} s{'' if row['finite'] else ', NOT FINITE'})"
    )


def write_rows(path: str | None, rows: list[dict], environment: dict | None, meta: dict) -> None:
    """The rows as ``harness.write_json`` lays them out (``environment`` from a child, since the
    parent starts no backend), written atomically."""
    if not path:
        return
    tmp = Path(f"{path}.tmp")
    tmp.write_text(json.dumps({"environment": environment, "meta": meta, "rows": rows}, indent=1))
    tmp.replace(path)


COLUMNS = [
    ("task", lambda r: r["task"]),
    ("envs", lambda r: r["envs"]),
    ("graph mode", lambda r: r["mode"]),
    ("command buffers", lambda r: r["command_buffers"]),
    ("ms / physics step", lambda r: f"{r['ms_per_physics_step']:.4f}" if "error" not in r else "-"),
    ("env steps/s", lambda r: harness.rate(r["env_steps_per_s"]) if "error" not in r else "-"),
    ("compile s", lambda r: f"{r['compile_s']:.1f}" if "error" not in r else r["error"][:60]),
]


def main(argv: Sequence[str] | None = None) -> None:
    args = parse_args(argv)
    if args.child:
        child_main(args)
        return
    from jaxpg import envs as envs_lib

    unknown = [task for task, _ in args.pairs if task not in envs_lib.names()]
    if unknown:
        print(f"error: unknown task {unknown[0]!r}; known: {', '.join(envs_lib.names())}", file=sys.stderr)
        raise SystemExit(2)
    pending = work(args.pairs, args.modes, args.command_buffers)[: 1 if args.profile else None]
    meta = {"steps": args.steps, "repeats": args.repeats, "plan": args.pairs, "on_commands": ON_COMMANDS}
    path = os.pathsep.join(filter(None, [str(harness.ROOT), os.environ.get("PYTHONPATH")]))
    rows: list[dict] = []
    environment = None
    deadline = time.perf_counter() + args.budget
    while pending:
        if time.perf_counter() >= deadline:
            print(f"budget of {args.budget:.0f} s spent: {len(pending)} rows not run", flush=True)
            rows += [not_run(item, "not run: budget spent") for item in pending]
            break
        setting = pending[0][0]
        items = pending[: next((i for i, item in enumerate(pending) if item[0] != setting), len(pending))]
        flags = xla_flags(setting, os.environ.get("XLA_FLAGS", ""), profiling=bool(args.profile))
        env = {**os.environ, "PYTHONPATH": path, "PYTHONUNBUFFERED": "1", "XLA_FLAGS": flags}
        print(f"# child: command buffers {setting}, {len(items)} rows, XLA_FLAGS={flags!r}", flush=True)
        found, child_env, ended = run_child(child_command(args, setting, items), env, args.row_timeout, deadline)
        rows += found
        environment = environment or child_env
        done = len(found)
        if done < len(items):  # the row it was on when it ended; a fresh child takes the rest
            print(f"# child ended: {ended}", flush=True)
            rows.append(not_run(items[done], f"child ended: {ended}"))
            print(progress_line(rows[-1]), flush=True)
            done += 1
        pending = pending[done:]
        write_rows(args.json, rows, environment, meta)
    write_rows(args.json, rows, environment, meta)
    print()
    if environment:
        print(", ".join(f"{key} {environment[key]}" for key in ("device", "backend", "jax", "mujoco", "warp-lang")))
    print(f"{args.steps} env steps per call, median of {args.repeats} calls\n")
    print(harness.table(rows, COLUMNS))
    for row in rows:
        if "profile" in row:
            print("\nprofile of the first row: " + json.dumps(row["profile"], indent=1))


def not_run(item: tuple[str, str, str, int], why: str) -> dict[str, Any]:
    """The row of an item ``(setting, mode, task, envs)`` that gave no measurement."""
    setting, mode, task, envs = item
    return {"task": task, "envs": envs, "mode": mode, "command_buffers": setting, "error": why}


if __name__ == "__main__":
    main()
