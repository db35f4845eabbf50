"""``throughput.py train``: training throughput against raw simulation of the same batch (its doc: ``TRAIN_DOC``)."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Sequence

import harness
import jax
import jax.numpy as jnp
import numpy as np

from jaxpg import envs

RAW = argparse.RawDescriptionHelpFormatter
SCRIPT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "throughput.py")


TRAIN_DOC = """Training throughput against raw simulation, side by side, per implementation and batch size.

For each (impl, num_envs) this measures, in a fresh process (so that peak memory is its own):
  raw    env steps/s of the simulation a training iteration needs: the same env (auto-reset
         included), batch and horizon, random actions, ``lax.scan`` over the horizon, each timed
         call continuing from the previous call's env states as training does ("raw from reset":
         every call from the same reset states, this benchmark's baseline before the benchmark record's
         section AK, where the two agreed), timed before anything else is compiled,
         and again after training ("raw after training": with the training programs and states
         resident too) and in the rounds that time training, one raw call after each scan and
         each group of single calls ("raw in the training rounds": both sides timed in the same
         state of the process and the GPU; the benchmark record, section AS);
  train  env steps/s of full training iterations (sampling, GAE, policy step, value fit), several
         iterations per compiled call exactly as ``jaxpg.train`` runs them, and one per call
         (``jax.jit(update)`` called back to back), the two timed alternately from the same state (since
         the benchmark record section AK; before, one iteration per call was timed after the scan, on a
         more trained policy, as one timing of ``3 x iterations`` unsynchronised calls);
and reports their ratio, both compile times and the peak device memory per env.

With ``--preset NAME`` the algorithm runs that preset (at each batch size) instead of a
throughput-oriented config, mean-policy evaluation included: one evaluation
(``jaxpg.train.evaluate_state``, as ``jaxpg.train`` runs it between compiled calls) is timed and
charged once per ``eval_every`` iterations, as a run of the preset pays it ("train+eval").

    python benchmarks/throughput.py train --task hopper --impl warp jax \
        --batch-sizes 256 1024 4096 16384 65536 --horizon 32 --algo npg
    python benchmarks/throughput.py train --impl warp --preset hopper --horizon 64 \
        --batch-sizes 256 1024 4096 16384 65536
"""


def algo_config(
    algo: str, num_envs: int, horizon: int, preset: str | None = None, overrides: dict | None = None
) -> object:
    """``preset`` (with ``overrides``) at this batch, or a throughput-oriented config: no
    evaluation rollouts, large value minibatches."""
    from jaxpg import algos

    module = algos.get(algo)
    if preset:
        return module.Config(
            **{**module.PRESETS[preset], **(overrides or {}), "num_envs": num_envs, "horizon": horizon}
        )
    samples = num_envs * horizon
    fields = module.Config.__dataclass_fields__
    overrides = dict(num_envs=num_envs, horizon=horizon, eval_envs=0, normalize_observations=True)
    if "value_batch_size" in fields:
        overrides.update(value_batch_size=max(64, samples // 8), value_epochs=2)
    if "num_minibatches" in fields:
        overrides.update(num_minibatches=8, num_epochs=2)
    return module.Config(**overrides)


def train_measure(
    task: str,
    impl: str,
    fidelity: str,
    num_envs: int,
    horizon: int,
    algo: str,
    iterations: int,
    preset: str | None,
    overrides: dict | None = None,
    repeats: int = 3,
) -> dict:
    """One row of the table (runs in its own process). Every time is the median of ``repeats``
    synchronised calls of ``iterations`` iterations (raw: of as many horizons)."""
    from jaxpg import algos
    from jaxpg import rollout as rollout_lib
    from jaxpg import train as train_lib

    env = envs.make(task, batch=num_envs, impl=impl, fidelity=fidelity)
    sampler = envs.AutoReset(env)
    state = rollout_lib.reset_batch(sampler, jax.random.PRNGKey(0), num_envs)

    def random_act(params, obs, key):  # noqa: ANN001, ANN202
        del params
        if env.discrete:
            return jax.random.randint(key, obs.shape[:1], 0, env.action_size), jnp.zeros(obs.shape[0])
        shape = (obs.shape[0], env.action_size)
        return jax.random.uniform(key, shape, minval=-1.0, maxval=1.0), jnp.zeros(obs.shape[0])

    @jax.jit
    def raw(state, key):  # noqa: ANN001, ANN202
        def one(state, key):  # noqa: ANN001, ANN202
            state, traj = rollout_lib.rollout(sampler, random_act, None, state, key, horizon)
            return state, jnp.sum(traj.rewards)

        return jax.lax.scan(one, state, jax.random.split(key, iterations))

    # Raw simulation from the same reset state in every timed call (as this benchmark measured it
    # up to section AK of the benchmark record), which might favour the first steps after a reset ...
    raw_compile, raw_fresh_s, _ = harness.time_call(raw, state, jax.random.PRNGKey(1), repeats=repeats)
    raw_fresh_s /= iterations

    # ... and chained, each call continuing from the last one's env states (and key), in the
    # steady state of resets and contacts that training runs in: the baseline of train/raw.
    @jax.jit
    def raw_chained(carry):  # noqa: ANN001, ANN202
        env_state, key = carry
        key, call_key = jax.random.split(key)
        env_state, rewards = raw(env_state, call_key)
        return (env_state, key), rewards

    carry, _ = jax.block_until_ready(raw_chained((state, jax.random.PRNGKey(2))))
    carry, _ = jax.block_until_ready(raw_chained(carry))
    raw_s, (carry, _) = harness.time_chained(raw_chained, carry, repeats)
    raw_s /= iterations

    module = algos.get(algo)
    config = algo_config(algo, num_envs, horizon, preset, overrides)
    # Commit every leaf to the device first. A state built eagerly mixes uncommitted leaves with
    # committed ones (MuJoCo Warp's buffers), while a jitted call's outputs are all committed, and
    # jit compiles a separate executable for each mix: without this the first timed call after
    # the compiling call compiled the whole program again, which an earlier version of this
    # benchmark reported as a 10-17x slower scan (docs/benchmarks_archive.md, section M).
    ts = jax.device_put(module.init(jax.random.PRNGKey(0), env, config), jax.devices()[0])
    # Several iterations in one compiled lax.scan, as jaxpg.train runs them by default ...
    block = jax.jit(lambda ts: train_lib.scan_updates(module.update, ts, iterations))
    start = time.perf_counter()
    ts2, metrics = jax.block_until_ready(block(ts))
    train_compile = time.perf_counter() - start
    ts2, metrics = jax.block_until_ready(block(ts2))  # warm-up with the call's own outputs
    # ... against one iteration per compiled call (jax.jit(update)): the same
    # number of calls dispatched back to back, synchronised once. The two chains start from the
    # same state and alternate, so that both time the same stage of training (the physics of a
    # policy that has learned to hop costs differently from one that falls), and each figure is
    # the median of `repeats` synchronised groups.
    single = jax.jit(module.update)
    ts_single, _ = jax.block_until_ready(single(ts2))
    ts_single, _ = jax.block_until_ready(single(ts_single))
    ts_single = ts2
    # Raw simulation is timed a third way in the same rounds (its chain continued), so that raw
    # and training are also compared in the same state of the process and the GPU: timed alone
    # before anything else, raw ran faster than after training (the benchmark record, section AS).
    scan_times, single_times, raw_round_times = [], [], []
    for _ in range(repeats):
        start = time.perf_counter()
        ts2, metrics = jax.block_until_ready(block(ts2))
        scan_times.append(time.perf_counter() - start)
        start = time.perf_counter()
        for _ in range(iterations):
            ts_single, _ = single(ts_single)
        jax.block_until_ready(ts_single)
        single_times.append(time.perf_counter() - start)
        start = time.perf_counter()
        carry, _ = jax.block_until_ready(raw_chained(carry))
        raw_round_times.append(time.perf_counter() - start)
    train_s = float(np.median(scan_times)) / iterations
    single_s = float(np.median(single_times)) / iterations
    raw_rounds_s = float(np.median(raw_round_times)) / iterations
    # The sampling phase alone (the policy acting in the env batch, observation statistics
    # included), iterations of it in one compiled call: what training adds to the simulation
    # (sample - raw) apart from what the learner adds (train - sample).
    from jaxpg.algos import core

    def sample_only(ts):  # noqa: ANN001, ANN202
        def one(ts, _):  # noqa: ANN001, ANN202
            ts, traj, _ = core.phase_sample(ts)
            return ts, jnp.sum(traj.rewards)

        return jax.lax.scan(one, ts, None, length=iterations)

    sample_block = jax.jit(sample_only)
    ts_s, _ = jax.block_until_ready(sample_block(ts2))
    ts_s, _ = jax.block_until_ready(sample_block(ts_s))
    sample_s, _ = harness.time_chained(sample_block, ts_s, repeats)
    sample_s /= iterations
    samples = num_envs * horizon
    eval_s, eval_compile = 0.0, 0.0
    if config.eval_envs > 0:
        evaluate = train_lib.compiled_evaluate(train_lib.evaluate_state, False)
        eval_compile, eval_s, _ = harness.time_call(evaluate, ts_single, repeats=3)
    # Raw simulation once more, continuing its chain, in calls of its own after all training (the
    # first raw timing ran with only the raw program's buffers allocated): with the rounds above,
    # a second reading of raw timed in the same state of the process as training.
    raw_after_s, _ = harness.time_chained(raw_chained, carry, repeats)
    raw_after_s /= iterations
    with_eval_s = train_s + eval_s / config.eval_every  # per iteration, evaluation amortised
    stats = jax.devices()[0].memory_stats() or {}
    peak = stats.get("peak_bytes_in_use", 0)
    return {
        "task": task,
        "impl": env.unwrapped.impl,
        "fidelity": fidelity,
        "algo": algo,
        "num_envs": num_envs,
        "horizon": horizon,
        "raw_steps_per_s": samples / raw_s,
        "raw_fresh_steps_per_s": samples / raw_fresh_s,
        "ratio_fresh": raw_fresh_s / train_s,
        "train_steps_per_s": samples / train_s,
        "ratio": raw_s / train_s,
        "raw_after_steps_per_s": samples / raw_after_s,
        "ratio_after": raw_after_s / train_s,
        "raw_rounds_steps_per_s": samples / raw_rounds_s,
        "ratio_rounds": raw_rounds_s / train_s,
        "sample_steps_per_s": samples / sample_s,
        "ratio_sample": raw_s / sample_s,
        "repeats": repeats,
        "train_single_steps_per_s": samples / single_s,
        "ratio_single": raw_s / single_s,
        "preset": preset,
        "overrides": overrides or {},
        "eval_s": eval_s,
        "eval_compile_s": eval_compile,
        "eval_every": config.eval_every if config.eval_envs > 0 else 0,
        "train_eval_steps_per_s": samples / with_eval_s,
        "ratio_eval": raw_s / with_eval_s,
        "raw_compile_s": raw_compile,
        "train_compile_s": train_compile,
        "peak_bytes_per_env": peak / num_envs,
        "device": jax.devices()[0].device_kind,
    }


def train_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="throughput.py train", description=TRAIN_DOC, formatter_class=RAW)
    parser.add_argument("--task", default="hopper")
    parser.add_argument("--algo", default="npg")
    parser.add_argument("--impl", nargs="+", default=["jax"])
    parser.add_argument("--fidelity", default="fast")
    parser.add_argument("--batch-sizes", nargs="+", type=int, default=[256, 1024])
    parser.add_argument("--horizon", type=int, default=32)
    parser.add_argument("--iterations", type=int, default=5, help="iterations per timed compiled call")
    parser.add_argument("--repeats", type=int, default=3, help="timed calls per figure (their median is reported)")
    parser.add_argument("--preset", help="the algorithm's preset (with its evaluation) instead of a throughput config")
    parser.add_argument(
        "--set", nargs="+", default=[], metavar="FIELD=JSON", help="preset overrides, e.g. value_epoch_samples=65536"
    )
    parser.add_argument("--json", help="write all rows to this file")
    parser.add_argument("--single", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    overrides = {k: json.loads(v) for k, v in (item.split("=", 1) for item in args.set)}

    if args.single:
        impl, num_envs = args.single.split(":")
        row = train_measure(
            args.task,
            impl,
            args.fidelity,
            int(num_envs),
            args.horizon,
            args.algo,
            args.iterations,
            args.preset,
            overrides,
            args.repeats,
        )
        print("ROW " + json.dumps(row), flush=True)
        return

    rows = []
    for impl in args.impl:
        for num_envs in args.batch_sizes:
            cmd = [sys.executable, SCRIPT, "train", "--single", f"{impl}:{num_envs}"]
            cmd += ["--task", args.task, "--algo", args.algo, "--fidelity", args.fidelity]
            cmd += ["--horizon", str(args.horizon), "--iterations", str(args.iterations)]
            cmd += ["--repeats", str(args.repeats)]
            cmd += ["--preset", args.preset] if args.preset else []
            cmd += ["--set", *args.set] if args.set else []
            proc = subprocess.run(cmd, capture_output=True, text=True)
            found = [line for line in proc.stdout.splitlines() if line.startswith("ROW ")]
            if proc.returncode != 0 or not found:
                print(f"# {impl} {num_envs}: failed\n{proc.stderr[-2000:]}", flush=True)
                continue
            row = json.loads(found[0][4:])
            rows.append(row)
            print(f"# {json.dumps(row)}", flush=True)
    harness.write_json(args.json, rows)
    device = rows[0]["device"] if rows else ""
    title = " ".join([args.task, args.algo, args.preset or "", *args.set])
    print(f"\n{title}, horizon {args.horizon}, fidelity {args.fidelity}, {device}")
    print("| impl | envs | raw env steps/s | train env steps/s | train/raw (raw timed first)", end="")
    print(" | compile raw s | compile train s", end="")
    print(" | peak MiB/env | 1 iter/call env steps/s | 1 iter/call train/raw | sampling alone/raw", end="")
    print(" | raw from reset env steps/s | train/raw from reset", end="")
    print(" | raw after training env steps/s | train/raw after", end="")
    print(" | raw in the training rounds env steps/s | train/raw in rounds |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['impl']} | {r['num_envs']} | {r['raw_steps_per_s'] / 1e6:.3f} M "
            f"| {r['train_steps_per_s'] / 1e6:.3f} M "
            f"| {r['ratio']:.2f} | {r['raw_compile_s']:.1f} | {r['train_compile_s']:.1f} | "
            f"{r['peak_bytes_per_env'] / 2**20:.3f} | {r['train_single_steps_per_s'] / 1e6:.3f} M "
            f"| {r['ratio_single']:.2f} | {r['ratio_sample']:.2f} | {r['raw_fresh_steps_per_s'] / 1e6:.3f} M "
            f"| {r['ratio_fresh']:.2f} | {r['raw_after_steps_per_s'] / 1e6:.3f} M | {r['ratio_after']:.2f} "
            f"| {r['raw_rounds_steps_per_s'] / 1e6:.3f} M | {r['ratio_rounds']:.2f} |"
        )
    if args.preset:
        print("\nwith evaluation at the preset's cadence (one evaluation per eval_every iterations):")
        print("| impl | envs | train+eval env steps/s | train+eval/raw | one evaluation s | eval every |")
        print("|---|---|---|---|---|---|")
        for r in rows:
            print(
                f"| {r['impl']} | {r['num_envs']} | {r['train_eval_steps_per_s'] / 1e6:.3f} M | {r['ratio_eval']:.2f} "
                f"| {r['eval_s']:.2f} | {r['eval_every']} |"
            )
