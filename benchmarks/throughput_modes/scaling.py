"""``throughput.py scaling``: NPG training over 1, 2, 4, ... devices at a fixed batch per device."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from collections.abc import Sequence
from typing import Any

import harness
import jax
import jax.numpy as jnp

from jaxpg import envs

RAW = argparse.RawDescriptionHelpFormatter


SCALING_DOC = """Scaling of NPG training over devices: env steps/s on 1, 2, 4, ... GPUs at a fixed batch per GPU.

For each device count ``k`` (in a fresh process; the env mesh over the first ``k`` of
``jax.devices()``), with ``k * --envs-per-device`` envs split over the ``k`` devices exactly as
``python -m jaxpg.cli`` splits them (``jaxpg.mesh``):

  raw       env steps/s of the simulation alone: the same env (automatic reset included), batch and
            horizon, random actions, each device stepping its own envs under ``jax.shard_map``;
  sample    env steps/s of NPG's sampling alone (the policy acting, ``core.phase_sample``);
  train     env steps/s of whole NPG iterations (sampling, GAE, gradient, CG on Fisher-vector
            products, value fit; the ``hopper_gpu`` preset without evaluation), compiled and
            called as ``jaxpg.train`` runs them (one iteration per call with MuJoCo Warp);
  eff.      scaling efficiency ``steps_k / (k * steps_1)`` of train (and of raw);
  compile   seconds of the first training call (compilation included).

On the GPU machine (MuJoCo Warp is the default there), e.g. two GPUs:

    python benchmarks/throughput.py scaling --task hopper --envs-per-device 16384 --horizon 32 --json scaling.json

On the CPU, with forced host devices and tiny sizes (it runs; its timings mean nothing):

    XLA_FLAGS=--xla_force_host_platform_device_count=2 JAX_PLATFORMS=cpu \\
        python benchmarks/throughput.py scaling --task cartpole --envs-per-device 8 --horizon 4 --iterations 1
"""

BENCHMARKS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROOT = os.path.dirname(BENCHMARKS)
SCRIPT = os.path.join(BENCHMARKS, "throughput.py")  # the command line that runs each child


def npg_config(num_envs: int, horizon: int) -> Any:
    """``hopper_gpu`` NPG settings at ``num_envs x horizon``: no evaluation, 16 value minibatches
    (so the work per device stays fixed as devices are added)."""
    from jaxpg.algos import npg

    samples = num_envs * horizon
    settings = {**npg.PRESETS["hopper_gpu"], "num_envs": num_envs, "horizon": horizon, "eval_envs": 0}
    settings["value_batch_size"] = max(16, samples // 16)
    return npg.Config(**settings)


def scaling_measure(
    task: str, impl: str | None, devices: int, envs_per_device: int, horizon: int, iterations: int
) -> dict:
    """One row: ``devices`` devices, ``devices * envs_per_device`` envs (runs in its own process)."""
    import jax

    from jaxpg import mesh as mesh_lib
    from jaxpg import rollout as rollout_lib
    from jaxpg import train
    from jaxpg.algos import core, npg
    from jaxpg.algos.core import shard_state

    if jax.device_count() < devices:
        raise SystemExit(f"only {jax.device_count()} devices are visible, {devices} asked for")
    mesh = mesh_lib.env_mesh(jax.devices()[:devices])
    num_envs = devices * envs_per_device
    env_kwargs = {"impl": impl} if impl else {}
    env = envs.make(task, batch=envs_per_device, **env_kwargs)
    config = npg_config(num_envs, horizon)
    ts = shard_state(npg.init(jax.random.PRNGKey(0), env, config), vmap_seeds=False, mesh=mesh)
    samples = num_envs * horizon

    # raw: random actions, the env batch split over the devices as sampling splits it
    sampler = core.sampler_env(ts.env, ts.config)
    state_specs = jax.tree.map(mesh_lib.batch_spec, core.env_batch_mask(sampler, ts.env_state))

    def random_act(params: Any, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        del params
        if env.discrete:
            return jax.random.randint(key, obs.shape[:1], 0, env.action_size), jnp.zeros(obs.shape[0])
        action = jax.random.uniform(key, (obs.shape[0], env.action_size), minval=-1.0, maxval=1.0)
        return action, jnp.zeros(obs.shape[0])

    def raw_step(carry: tuple) -> tuple:
        state, key = carry
        key, step_key = jax.random.split(key)

        def simulate(state: Any, key: jax.Array, rows: Any) -> Any:
            return rollout_lib.rollout(sampler, random_act, None, state, key, horizon)[0]

        specs = (state_specs, core.REPLICATED)
        state = core.split_over_envs(simulate, num_envs, specs, state_specs, state, step_key)
        return (state, key), None

    raw = jax.jit(mesh_lib.on_mesh(raw_step, mesh), donate_argnums=0)
    raw_copy = jax.tree.map(jnp.copy, ts.env_state)
    raw_first, raw_s, _ = harness.time_back_to_back(
        raw, (raw_copy, mesh_lib.replicated(jax.random.PRNGKey(1), mesh)), iterations
    )

    # sample: NPG's sampling alone, the policy acting
    def sample_step(ts: Any) -> tuple:
        ts, traj, _ = core.phase_sample(ts)
        return ts, jnp.mean(traj.rewards)

    sample = jax.jit(mesh_lib.on_mesh(sample_step, mesh), donate_argnums=0)
    _, sample_s, _ = harness.time_back_to_back(sample, jax.tree.map(jnp.copy, ts), iterations)

    # train: whole iterations, compiled and called as jaxpg.train does (one scan per block)
    per_call = iterations
    block = train.compiled_block(mesh_lib.on_mesh(npg.update, mesh), per_call, False)
    calls = max(iterations // per_call, 1)
    train_first, train_s, ts = harness.time_back_to_back(block, ts, calls)
    return {
        "task": task,
        "impl": getattr(env.unwrapped, "impl", "jax"),
        "devices": devices,
        "device_kind": jax.devices()[0].device_kind,
        "visible_devices": jax.device_count(),
        "envs_per_device": envs_per_device,
        "num_envs": num_envs,
        "horizon": horizon,
        "iterations_per_call": per_call,
        "raw_steps_per_s": samples / raw_s,
        "sample_steps_per_s": samples / sample_s,
        "train_steps_per_s": samples * per_call / train_s,
        "raw_compile_s": raw_first,
        "train_compile_s": train_first,
        "jax": jax.__version__,
    }


def device_counts(visible: int, asked: list[int] | None) -> list[int]:
    """``asked``, or 1, 2, 4, ... up to ``visible`` (and ``visible`` itself)."""
    if asked:
        return asked
    counts, k = [], 1
    while k <= visible:
        counts.append(k)
        k *= 2
    return counts if counts[-1] == visible else [*counts, visible]


def run_child(args: argparse.Namespace, devices: int) -> dict | None:
    """``measure`` in a fresh process (its own memory and compilation); ``None`` if it failed."""
    cmd = [sys.executable, SCRIPT, "scaling", "--single", str(devices), "--task", args.task]
    cmd += ["--envs-per-device", str(args.envs_per_device), "--horizon", str(args.horizon)]
    cmd += ["--iterations", str(args.iterations)] + (["--impl", args.impl] if args.impl else [])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [ROOT, os.environ.get("PYTHONPATH")]))}
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=args.timeout)
    except subprocess.TimeoutExpired:
        print(f"# {devices} devices: no result within {args.timeout} s", flush=True)
        return None
    found = [line for line in proc.stdout.splitlines() if line.startswith("ROW ")]
    if proc.returncode != 0 or not found:
        print(f"# {devices} devices: failed\n{proc.stderr[-3000:]}", flush=True)
        return None
    return json.loads(found[0][4:])


def visible_devices() -> int:
    """How many devices JAX sees, asked in a child process so that this one never holds GPU memory."""
    code = "import jax; print('COUNT', jax.device_count())"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    found = [line for line in proc.stdout.splitlines() if line.startswith("COUNT ")]
    if not found:
        raise SystemExit(f"could not start JAX:\n{proc.stderr[-2000:]}")
    return int(found[0].split()[1])


def efficiencies(rows: list[dict]) -> list[dict]:
    """Adds ``train_efficiency`` and ``raw_efficiency``: ``steps_k / (k * steps_1)`` (needs k = 1)."""
    base = next((r for r in rows if r["devices"] == 1), None)
    for row in rows:
        for kind in ("train", "raw", "sample"):
            ideal = base[f"{kind}_steps_per_s"] * row["devices"] if base else float("nan")
            row[f"{kind}_efficiency"] = row[f"{kind}_steps_per_s"] / ideal
    return rows


def scaling_table(rows: list[dict]) -> str:
    """The Markdown table of the rows."""
    lines = [
        "| devices | envs | raw env steps/s | sample env steps/s | train env steps/s | train eff. | raw eff. "
        "| compile s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['devices']} | {r['num_envs']} | {r['raw_steps_per_s'] / 1e6:.3f} M "
            f"| {r['sample_steps_per_s'] / 1e6:.3f} M | {r['train_steps_per_s'] / 1e6:.3f} M "
            f"| {r['train_efficiency']:.2f} | {r['raw_efficiency']:.2f} | {r['train_compile_s']:.1f} |"
        )
    return "\n".join(lines)


def scaling_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="throughput.py scaling", description=SCALING_DOC, formatter_class=RAW)
    parser.add_argument("--task", default="hopper")
    parser.add_argument("--impl", choices=("jax", "warp"), help="MJX implementation (default: warp on a GPU)")
    parser.add_argument("--envs-per-device", type=int, default=16384)
    parser.add_argument("--horizon", type=int, default=32)
    parser.add_argument("--devices", type=int, nargs="+", help="device counts (default: 1, 2, 4, ... visible)")
    parser.add_argument("--iterations", type=int, default=5, help="timed iterations (and raw/sample rollouts)")
    parser.add_argument("--timeout", type=float, default=600, help="seconds per device count")
    parser.add_argument("--json", help="write the rows to this file")
    parser.add_argument("--single", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.single:
        row = scaling_measure(args.task, args.impl, args.single, args.envs_per_device, args.horizon, args.iterations)
        print("ROW " + json.dumps(row), flush=True)
        return

    rows = []
    for devices in device_counts(visible_devices(), args.devices):
        row = run_child(args, devices)
        if row is not None:
            rows.append(row)
            print(f"# {json.dumps(row)}", flush=True)
    rows = efficiencies(rows)
    harness.write_json(args.json, rows)
    if rows:
        r = rows[0]
        print(
            f"\nNPG on {r['task']} ({r['impl']}), {r['envs_per_device']} envs per device, horizon {r['horizon']}, "
            f"{r['device_kind']}, JAX {r['jax']}"
        )
        print(scaling_table(rows))
