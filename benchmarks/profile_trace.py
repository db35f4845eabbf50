"""Where an iteration's time goes on the GPU: a ``jax.profiler`` trace of the card's training block.

Builds the command line's Hopper (NPG ``hopper`` preset at ``--num-envs``), compiles a block of
``--iterations`` iterations (one ``lax.scan``, as ``jaxpg.train`` runs it), warms it up, then traces
one call with ``jax.profiler.trace`` and summarises the Perfetto trace it writes:

* the wall time of the call, the time some GPU stream is busy (the union of kernel intervals) and
  the idle rest (launch latency and host round trips show up here);
* the number of kernels per iteration and the mean kernel duration;
* the kernels with the largest total time.

``--block`` picks what the traced block runs per iteration: ``full`` (``npg.update``, the default),
``sample`` (only the rollout, ``core.phase_sample``) or ``raw`` (the same env batch stepped with
uniform random actions, no policy); the differences in kernels per iteration between them are
what the policy adds to each env step and what the learner adds to each iteration.

The raw trace stays in ``--out`` (open ``*.trace.json.gz`` in https://ui.perfetto.dev).

    python benchmarks/profile_trace.py --num-envs 256 --iterations 10 --out /tmp/trace
    python benchmarks/profile_trace.py --num-envs 1024 --block sample --out /tmp/trace-sample
"""

from __future__ import annotations

import argparse
import collections
import gzip
import json
import sys
import time
from pathlib import Path

import jax


def busy_union(intervals: list[tuple[float, float]]) -> float:
    """Total length covered by ``[(start, end), ...]`` (overlaps counted once)."""
    total, current_start, current_end = 0.0, None, None
    for start, end in sorted(intervals):
        if current_end is None or start > current_end:
            if current_end is not None:
                total += current_end - current_start
            current_start, current_end = start, end
        else:
            current_end = max(current_end, end)
    if current_end is not None:
        total += current_end - current_start
    return total


def device_kernels(trace: dict) -> list[dict]:
    """The complete events (``ph == "X"``) of the trace's GPU processes (named ``/device:GPU:...``)."""
    gpu_pids = {
        event["pid"]
        for event in trace["traceEvents"]
        if event.get("ph") == "M"
        and event.get("name") == "process_name"
        and "GPU" in str(event.get("args", {}).get("name", ""))
    }
    return [e for e in trace["traceEvents"] if e.get("ph") == "X" and e.get("pid") in gpu_pids and "dur" in e]


def summarise(trace_file: Path, wall_s: float, iterations: int, top: int) -> None:
    """Print the busy/idle split and the top kernels of one traced call."""
    with gzip.open(trace_file, "rt") as f:
        trace = json.load(f)
    kernels = device_kernels(trace)
    if not kernels:
        print(f"no GPU events in {trace_file}")
        return
    busy_us = busy_union([(e["ts"], e["ts"] + e["dur"]) for e in kernels])
    span_us = max(e["ts"] + e["dur"] for e in kernels) - min(e["ts"] for e in kernels)
    by_name: dict[str, list[float]] = collections.defaultdict(list)
    for e in kernels:
        by_name[e["name"]].append(e["dur"])
    print(f"\none traced call of {iterations} iterations: {wall_s * 1e3:.1f} ms wall")
    print("| measure | value |")
    print("|---|---|")
    print(f"| GPU span (first kernel start to last kernel end) | {span_us / 1e3:.1f} ms |")
    print(f"| GPU busy (union of kernel intervals) | {busy_us / 1e3:.1f} ms ({100 * busy_us / span_us:.0f}% of span) |")
    print(f"| GPU idle within span | {(span_us - busy_us) / 1e3:.1f} ms |")
    print(f"| kernels per iteration | {len(kernels) / iterations:,.0f} |")
    print(f"| mean kernel duration | {sum(e['dur'] for e in kernels) / len(kernels):.1f} us |")
    print(f"\ntop {top} kernels by total time:")
    print("| kernel | calls / iteration | total ms / iteration | mean us |")
    print("|---|---|---|---|")
    ranked = sorted(by_name.items(), key=lambda item: -sum(item[1]))[:top]
    for name, durations in ranked:
        short = name if len(name) <= 70 else name[:67] + "..."
        print(
            f"| `{short}` | {len(durations) / iterations:.0f} | {sum(durations) / iterations / 1e3:.2f} "
            f"| {sum(durations) / len(durations):.1f} |"
        )


def iteration_fn(block: str):  # noqa: ANN201
    """``ts -> (ts, metrics)``: the whole NPG iteration (``full``), its rollout alone (``sample``),
    or the rollout's env steps with uniform random actions in place of the policy (``raw``); the
    last two as ``iteration_ablation.py`` times them."""
    from jaxpg.algos import npg

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from iteration_ablation import rollout_only, sample_only

    return {"full": npg.update, "sample": sample_only, "raw": rollout_only(policy=False)}[block]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--num-envs", type=int, default=256)
    parser.add_argument("--iterations", type=int, default=10, help="iterations in the traced compiled call")
    parser.add_argument("--out", default="/tmp/jaxpg-trace", help="directory for the raw trace")
    parser.add_argument("--top", type=int, default=15)
    parser.add_argument("--block", choices=("full", "sample", "raw"), default="full", help="what an iteration runs")
    args = parser.parse_args()

    from jaxpg import envs
    from jaxpg import train as train_lib
    from jaxpg.algos import npg

    env = envs.make("hopper", batch=args.num_envs)
    config = npg.Config(**{**npg.PRESETS["hopper"], "num_envs": args.num_envs})
    state = jax.device_put(npg.init(jax.random.PRNGKey(0), env, config), jax.devices()[0])
    block = train_lib.compiled_block(iteration_fn(args.block), args.iterations, False)
    for _ in range(2):  # compile, then once more with the call's own outputs
        state, _ = jax.block_until_ready(block(state))
    out = Path(args.out)
    with jax.profiler.trace(str(out), create_perfetto_trace=True):
        start = time.perf_counter()
        state, _ = jax.block_until_ready(block(state))
        wall_s = time.perf_counter() - start
    print(
        f"hopper npg preset hopper, block {args.block}, {args.num_envs} envs x {config.horizon} steps, "
        f"{jax.devices()[0].device_kind}"
    )
    traces = sorted(out.rglob("*.trace.json.gz"))
    if not traces:
        print(f"no Perfetto trace under {out}")
        return
    summarise(traces[-1], wall_s, args.iterations, args.top)


if __name__ == "__main__":
    main()
