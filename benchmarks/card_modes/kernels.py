"""``card_command.py kernels``: MuJoCo Warp's kernel build for the card's Hopper, serial against parallel."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from typing import Any

import harness

from card_modes import SCRIPT

RAW = argparse.RawDescriptionHelpFormatter

KERNELS_DOC = """How long MuJoCo Warp's kernels for the card's Hopper take to build on a bare machine, one
after another at the first execution (as MJX builds them) or on all host cores while XLA
compiles (``jaxpg.envs.warp_kernels.KernelBuild``, what the command line does).

Each build runs in a fresh process with empty Warp, CUDA driver and XLA caches: 256 envs of the
card's Hopper stepped once (``AutoReset``, fidelity "fast", MuJoCo Warp), timing the XLA
compilation, the wait for the background build and the first execution (which builds whatever
is not built yet).

    python benchmarks/card_command.py kernels --builds serial parallel --json kernels.json
"""


def kernels_child(build: str) -> dict[str, Any]:
    """One build in this process: seconds of imports, XLA compilation, wait and first step."""
    start = time.perf_counter()
    import jax
    import jax.numpy as jnp

    from jaxpg import envs
    from jaxpg.envs.warp_kernels import KernelBuild

    row: dict[str, Any] = {"build": build, "import_s": time.perf_counter() - start}
    env = envs.AutoReset(envs.make("hopper", impl="warp", batch=256))
    states = jax.block_until_ready(jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), 256)))
    actions = jnp.zeros((256, env.action_size))
    t = time.perf_counter()
    kernels = KernelBuild.start(env) if build == "parallel" else None
    step = jax.jit(jax.vmap(env.step))
    step.lower(states, actions).compile()
    row["xla_compile_s"] = time.perf_counter() - t
    t = time.perf_counter()
    if kernels is not None:
        kernels.wait()
        row.update(
            modules=kernels.modules, build_s=kernels.seconds, error=repr(kernels.error) if kernels.error else None
        )
    row["wait_s"] = time.perf_counter() - t
    t = time.perf_counter()
    jax.block_until_ready(step(states, actions))
    row["first_step_s"] = time.perf_counter() - t
    row["total_s"] = time.perf_counter() - start
    return row


def kernels_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="card_command.py kernels", description=KERNELS_DOC, formatter_class=RAW)
    parser.add_argument("--builds", nargs="+", choices=("serial", "parallel"), default=["serial", "parallel"])
    parser.add_argument("--child", choices=("serial", "parallel"), help=argparse.SUPPRESS)
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    if args.child:
        print("ROW " + json.dumps(kernels_child(args.child)), flush=True)
        return
    rows = []
    for build in args.builds:
        with tempfile.TemporaryDirectory() as caches:
            env = {
                **os.environ,
                "WARP_CACHE_PATH": f"{caches}/warp",
                "CUDA_CACHE_PATH": f"{caches}/cuda",
                "JAX_COMPILATION_CACHE_DIR": "",
            }
            out = subprocess.run(
                [sys.executable, str(SCRIPT), "kernels", "--child", build], env=env, capture_output=True, text=True
            )
        lines = [line for line in out.stdout.splitlines() if line.startswith("ROW ")]
        if not lines:
            raise SystemExit(f"the {build} build failed:\n{out.stderr[-3000:]}")
        rows.append(json.loads(lines[-1][4:]))
        print(f"  {build}: {rows[-1]}", flush=True)
    print(f"\n{harness.describe()}")
    print("| build | imports s | XLA compile s | waiting for the build s | first step s | whole process s |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        cells = [r["import_s"], r["xla_compile_s"], r["wait_s"], r["first_step_s"], r["total_s"]]
        print(f"| {r['build']} | " + " | ".join(f"{x:.1f}" for x in cells) + " |")
    harness.write_json(args.json, rows, argv=list(argv))
