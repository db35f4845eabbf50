"""``card_command.py memory``: the GPU backend start and its first buffers, with memory preallocated and on demand."""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from collections.abc import Sequence

import harness

from card_modes import ROOT

RAW = argparse.RawDescriptionHelpFormatter

# A fresh process's GPU start, in seconds (JSON): ``import jax``, the backend (``jax.devices()``),
# the first buffer (where JAX's client reserves its memory pool unless told not to), 500 more small
# buffers, ``import mujoco.mjx`` (MuJoCo Warp's modules included) and MJX's Warp ``put_model`` of
# the card's Hopper, twice.
MEMORY_SNIPPET = """
import json, sys, time
import numpy as np
t0 = time.perf_counter(); import jax, jax.numpy as jnp
t1 = time.perf_counter(); jax.devices()
t2 = time.perf_counter(); jnp.zeros(1).block_until_ready()
t3 = time.perf_counter(); jax.block_until_ready(jax.device_put([np.ones(3, np.float32) for _ in range(500)]))
t4 = time.perf_counter(); import mujoco; from mujoco import mjx
t5 = time.perf_counter(); model = mujoco.MjModel.from_xml_path(sys.argv[1])
jax.block_until_ready(mjx.put_model(model, impl="warp"))
t6 = time.perf_counter(); jax.block_until_ready(mjx.put_model(model, impl="warp"))
t7 = time.perf_counter()
print(json.dumps({"import jax": t1 - t0, "backend": t2 - t1, "first buffer": t3 - t2, "500 buffers": t4 - t3,
                  "import mjx": t5 - t4, "put_model": t6 - t5, "put_model again": t7 - t6}))
"""
MEMORY_PARTS = ("import jax", "backend", "first buffer", "500 buffers", "import mjx", "put_model", "put_model again")
MEMORY_SETTINGS = {"JAX's default (preallocate)": "true", "on demand (jaxpg's)": "false"}


def memory_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(
        prog="card_command.py memory",
        description="Fresh-process GPU start with JAX's memory reserved at the first buffer (its default) and "
        "taken on demand (XLA_PYTHON_CLIENT_PREALLOCATE=false), alternating; the card's Hopper put on the GPU "
        "by MJX's Warp put_model. A GPU and MuJoCo Warp are needed. For the whole card both ways: "
        "XLA_PYTHON_CLIENT_PREALLOCATE=true python benchmarks/card_command.py card ... (a value you set is kept).",
    )
    parser.add_argument("--repeats", type=int, default=3, help="processes per setting, alternating (default: 3)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    xml = str(ROOT / "jaxpg" / "envs" / "assets" / "hopper.xml")
    rows = []
    for repeat in range(args.repeats):
        for setting, value in MEMORY_SETTINGS.items():
            env = {**os.environ, "XLA_PYTHON_CLIENT_PREALLOCATE": value}
            done = subprocess.run(
                [sys.executable, "-c", MEMORY_SNIPPET, xml], cwd=ROOT, env=env, capture_output=True, text=True
            )
            if done.returncode != 0:
                raise SystemExit(f"error: the {setting} process failed: {done.stderr.strip().splitlines()[-1:]}")
            rows.append({"setting": setting, "repeat": repeat, **json.loads(done.stdout.strip().splitlines()[-1])})
    harness.write_json(args.json, rows, argv=list(argv))
    print(f"\n{harness.describe()}")
    columns = [(part, lambda r, part=part: f"{r[part]:.2f}") for part in MEMORY_PARTS]
    print(harness.table(rows, [("memory", lambda r: r["setting"])] + columns))
    for setting in MEMORY_SETTINGS:
        first = [r["first buffer"] for r in rows if r["setting"] == setting]
        print(f"{setting}: first buffer median {statistics.median(first):.2f} s over {len(first)} processes")
