"""``card_command.py startup``: the backend start and the MJX import in fresh processes; the card's start sampled."""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import harness

from card_modes import ROOT

RAW = argparse.RawDescriptionHelpFormatter

# Each snippet runs in a fresh process and prints its seconds as JSON: ``import jax``, JAX's
# backend start (``jax.devices()``) and ``import mujoco.mjx`` (MuJoCo Warp's modules included),
# in turn or with the import on a thread while the backend starts; then jaxpg's import of MJX
# (``jaxpg.envs.mjx_import``, jaxpg's own import counted in the total only), with MuJoCo Warp and
# with it left out (``JAXPG_MJX_WARP=off``, what a command that steps on JAX only does); "trimesh
# imported": trimesh imported first, as MJX did before jaxpg deferred it (``mjx_import.DeferredModule``).
STARTUP_SNIPPETS = {
    "in turn": """
import json, time
t0 = time.perf_counter(); import jax
t1 = time.perf_counter(); jax.devices()
t2 = time.perf_counter(); import mujoco.mjx
t3 = time.perf_counter()
print(json.dumps({"import jax": t1 - t0, "backend": t2 - t1, "import mjx": t3 - t2, "total": t3 - t0}))
""",
    "import on a thread": """
import json, threading, time
t0 = time.perf_counter(); import jax
t1 = time.perf_counter()
thread = threading.Thread(target=__import__, args=("mujoco.mjx",)); thread.start(); jax.devices()
t2 = time.perf_counter(); thread.join()
t3 = time.perf_counter()
print(json.dumps({"import jax": t1 - t0, "backend": t2 - t1, "import mjx": t3 - t2, "total": t3 - t0}))
""",
}

# jaxpg's import of MJX: ``{warp}`` sets ``JAXPG_MJX_WARP`` or nothing, ``{first}`` imports trimesh
# inside the timed import or nothing.
JAXPG_IMPORT_SNIPPET = """
import json, os, time
{warp}
t0 = time.perf_counter(); import jax
t1 = time.perf_counter(); jax.devices()
from jaxpg.envs import mjx_import
t2 = time.perf_counter(); {first}mjx_import.import_mjx()
t3 = time.perf_counter()
print(json.dumps({{"import jax": t1 - t0, "backend": t2 - t1, "import mjx": t3 - t2, "total": t3 - t0}}))
"""
STARTUP_SNIPPETS |= {
    f"jaxpg, {name}{trimesh}": JAXPG_IMPORT_SNIPPET.format(warp=warp, first=first)
    for name, warp in (("with Warp", ""), ("Warp left out", 'os.environ["JAXPG_MJX_WARP"] = "off"'))
    for trimesh, first in (("", ""), (", trimesh imported", "import trimesh; "))
}


# Runs the card's command (its flags after the first two arguments) while a thread writes the main
# thread's stack, innermost frame first, every 50 ms to the file named by the first argument.
SAMPLER = r"""
import os, runpy, sys, threading, time, traceback
path, main_thread, start = sys.argv[1], threading.get_ident(), time.perf_counter()
seconds = float(sys.argv[2])
def sample():
    with open(path, "w") as out:
        while time.perf_counter() - start < seconds:
            frame = sys._current_frames().get(main_thread)
            if frame is not None:
                stack = [f"{f.filename}:{f.name}" for f in traceback.extract_stack(frame)[::-1]]
                out.write(f"{time.perf_counter() - start:.2f}\t" + ";".join(stack[:60]) + "\n")
                out.flush()  # the run ends with os._exit, which flushes nothing
            time.sleep(0.05)
threading.Thread(target=sample, daemon=True).start()
sys.argv = ["experiments/hopper.py", *sys.argv[3:]]
runpy.run_path("experiments/hopper.py", run_name="__main__")
"""


def sampled_activity(stack: str) -> str:
    """What one sample's main thread was doing: ``import`` while a module is being imported, else
    its innermost jaxpg frame (``file.py:function``), else its innermost frame."""
    frames = stack.split(";")
    if any("_find_and_load" in frame for frame in frames):
        return "import"
    ours = [frame for frame in frames if "/jaxpg/" in frame]
    return (ours[0] if ours else frames[0]).rsplit("/", 1)[-1]


def sample_card(out: Path, extra: list[str], runs: int) -> list[dict[str, Any]]:
    """A first run that fills the caches, then ``runs`` sampled warm runs of the card's command:
    per run, the seconds to the `training:` line and the seconds each activity took before it."""
    env = {
        "JAXPG_COMPILATION_CACHE": str(out / "caches" / "xla"),
        "WARP_CACHE_PATH": str(out / "caches" / "warp"),
        "CUDA_CACHE_PATH": str(out / "caches" / "cuda"),
    }
    card = ["--num-envs", "256", "--no-progress", *extra]
    fill = [sys.executable, "experiments/hopper.py", *card, "--run-dir", str(out / "fill")]
    harness.run_process(fill, env, out / "fill.log")
    rows = []
    for run in range(runs):
        samples = out / f"samples{run}.txt"
        command = [sys.executable, "-c", SAMPLER, str(samples), "30", *card, "--run-dir", str(out / f"sampled{run}")]
        _, wall, stamped = harness.run_process(command, env, out / f"sampled{run}.log")
        training = next((t for t, line in stamped if line.startswith("training: ")), wall)
        activity: dict[str, float] = {}
        taken = [(float(t), stack) for t, stack in (line.split("\t", 1) for line in samples.read_text().splitlines())]
        for (seconds, stack), (following, _) in zip(taken, [*taken[1:], (training, "")], strict=True):
            if seconds < training:  # each sample stands for the time until the next one
                name = sampled_activity(stack)
                activity[name] = activity.get(name, 0.0) + min(following, training) - seconds
        rows.append({"run": run, "to_training_s": training, "wall_s": wall, "activity_s": activity})
    return rows


def startup_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(
        prog="card_command.py startup",
        description="Fresh-process start-up: JAX's backend and `import mujoco.mjx`, in turn or overlapped "
        "(`import mjx` is then what is left of the import after the backend started), and jaxpg's import of "
        "MJX with MuJoCo Warp and without (`backend` then includes importing jaxpg).",
    )
    parser.add_argument("--repeats", type=int, default=3, help="processes per order, alternating (default: 3)")
    parser.add_argument("--sample", type=int, default=0, help="instead: this many sampled warm runs of the card")
    parser.add_argument("--out", default=None, help="--sample's runs and samples (default: a temporary directory)")
    parser.add_argument("--json", default=None)
    parser.add_argument("--extra", nargs=argparse.REMAINDER, default=[], help="--sample: flags added to the card's")
    args = parser.parse_args(argv)
    if args.sample:
        out = Path(args.out or tempfile.mkdtemp(prefix="card-sample-"))
        out.mkdir(parents=True, exist_ok=True)
        sampled = sample_card(out, args.extra, args.sample)
        harness.write_json(args.json, sampled, argv=list(argv))
        print(f"\n{harness.describe()}")
        for row in sampled:
            seconds_to, wall = row["to_training_s"], row["wall_s"]
            print(f"run {row['run']}: `training:` after {seconds_to:.2f} s, whole process {wall:.1f} s")
            for name, seconds in sorted(row["activity_s"].items(), key=lambda kv: -kv[1])[:12]:
                print(f"  {seconds:5.2f} s  {name}")
        print("(a sample every 50 ms or more, an import may delay one; each counts until the next)")
        return
    rows = []
    for repeat in range(args.repeats):
        for order, code in STARTUP_SNIPPETS.items():
            done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
            if done.returncode != 0:
                raise SystemExit(f"error: the {order} snippet failed: {done.stderr.strip().splitlines()[-1:]}")
            rows.append({"order": order, "repeat": repeat, **json.loads(done.stdout.strip().splitlines()[-1])})
    harness.write_json(args.json, rows, argv=list(argv))
    print(f"\n{harness.describe()}")
    parts = ("import jax", "backend", "import mjx", "total")
    print(harness.table(rows, [("order", lambda r: r["order"])] + [(p, lambda r, p=p: f"{r[p]:.2f}") for p in parts]))
    for order in STARTUP_SNIPPETS:
        totals = [r["total"] for r in rows if r["order"] == order]
        print(f"{order}: median {statistics.median(totals):.2f} s over {len(totals)} processes")
