"""Throughput: how many env steps per second the simulation, training and its pieces run at.

One script, six modes (``python benchmarks/throughput.py MODE --help`` for each):

  env       raw environment throughput, random actions, no policy: the physics alone, the bare
            task and the env a sampler steps (wrappers and automatic reset);
  train     training throughput against raw simulation of the same batch, per implementation and
            batch size (each in a fresh process), optionally with a preset's evaluation charged;
  scaling   NPG training over 1, 2, 4, ... devices at a fixed batch per device;
  learner   GAE and the value fit in several equivalent forms, timed alone;
  eval      what one mean-policy evaluation costs, with and without its early stop;
  host      the host's work after each block of a many-seed run (metrics, curves, a checkpoint).

Every figure is timed with ``benchmarks/harness.py`` (synchronised calls, median of repeats) and
every mode prints a Markdown table; ``--json`` writes the rows.
Lettered sections cited below are those of the benchmark record, ``docs/benchmarks_archive.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import harness
import jax
import jax.numpy as jnp
import numpy as np
import optax

from jaxpg import envs, returns
from jaxpg import value as value_lib
from jaxpg.policies import ValueFunction

RAW = argparse.RawDescriptionHelpFormatter


# ========================================================================================== env

ENV_DOC = """Raw environment throughput: env steps/s with random actions, no policy.

Every measurement ``vmap``s over ``--batch-sizes`` envs and ``lax.scan``s over ``--horizon`` env
steps inside one jitted call, timed after compilation (compile time reported apart), for three
variants of the same task:

  raw   the physics alone: ``frame_skip`` ``mjx.step`` calls per env step on ``mjx.Data`` (CartPole:
        its dynamics function); no observation, reward, guard, wrapper or reset;
  task  the bare task's ``step``: physics plus observation, reward, termination, time limit and the
        non-finite guard;
  env   what a sampler steps: ``jaxpg.envs.make``'s wrappers (``ClipAction``, ``EpisodeStats``)
        and ``AutoReset`` on top, which computes a fresh reset state at every step;
  env_all  ``env`` with the reset selecting every field of the physics data (MJX's ``Data.where``),
        not only those the next step reads (``MjxEnv.select_physics``).

``env / raw`` is the fraction of the simulation's speed that jaxpg's env keeps. Drawing the random
actions is part of every variant. All variants of a task and batch size are compiled first, then
timed in turn, one call each per round with the order rotating from round to round, so that a
drift of the machine's speed during the measurement falls on all of them alike.

    python benchmarks/throughput.py env --tasks hopper inverted_pendulum --batch-sizes 1024 4096 \\
        --fidelity fast gymnasium --impl jax warp --horizon 100 --json env.json

On the CPU, with tiny sizes: ``--tasks cartpole inverted_pendulum --batch-sizes 4 --horizon 10``.
"""

VARIANTS = ("raw", "task", "env", "env_all")


def random_actions(env: envs.Env, key: jax.Array, batch: int) -> jax.Array:
    """``[batch, ...]`` uniform random actions in the task's range (int32 choices if discrete)."""
    if env.discrete:
        return jax.random.randint(key, (batch,), 0, env.action_size)
    return jax.random.uniform(key, (batch, env.action_size), minval=env.action_low, maxval=env.action_high)


def make_runner(variant: str, name: str, kwargs: dict, batch: int, horizon: int) -> tuple[Callable, Callable]:
    """``(init(key) -> carry, run(carry, key) -> carry)`` of one variant of task ``name`` made with
    ``kwargs``; ``run`` takes ``horizon`` steps of ``batch`` envs and is the function timed."""
    task = envs.make_task(name, **kwargs)
    if variant == "raw":
        if envs.is_mjx(name):
            init_one = lambda key: task.reset(key).data
            step_one = task.physics_step
        else:  # CartPole: the dynamics on the bare state vector
            init_one = lambda key: task.reset(key).data.state
            step_one = task.dynamics
    else:
        env = task if variant == "task" else envs.AutoReset(envs.make(name, **kwargs))
        if variant == "env_all" and envs.is_mjx(name):
            env.unwrapped.select_physics = lambda pick_new, new, old: old.where(pick_new, new)
        init_one, step_one = env.reset, env.step

    def init(key: jax.Array) -> Any:
        return jax.vmap(init_one)(jax.random.split(key, batch))

    def run(carry: Any, key: jax.Array) -> Any:
        def body(carry: Any, step_key: jax.Array) -> tuple[Any, None]:
            return jax.vmap(step_one)(carry, random_actions(task, step_key, batch)), None

        carry, _ = jax.lax.scan(body, carry, jax.random.split(key, horizon))
        return carry

    return jax.jit(init), jax.jit(run)


def env_measure(variants: Sequence[str], name: str, kwargs: dict, batch: int, horizon: int, repeats: int) -> dict:
    """``{variant: {compile_s, steps_per_s, finite}}``: each variant's compile time and env steps/s
    (median over ``repeats`` rounds, each timing every variant once, in rotating order)."""
    keys = jax.random.split(jax.random.key(1), repeats + 2)
    compiled, chains, compile_s = {}, {}, {}
    for variant in variants:
        init, run = make_runner(variant, name, kwargs, batch, horizon)
        carry = jax.block_until_ready(init(jax.random.key(0)))
        start = time.perf_counter()
        compiled[variant] = run.lower(carry, keys[-1]).compile()
        compile_s[variant] = time.perf_counter() - start
        chains[variant] = [jax.block_until_ready(compiled[variant](carry, keys[0]))]  # warm-up call
    seconds: dict[str, list[float]] = {v: [] for v in variants}
    for i in range(1, repeats + 1):
        for variant in variants[i % len(variants) :] + variants[: i % len(variants)]:
            start = time.perf_counter()
            chains[variant].append(jax.block_until_ready(compiled[variant](chains[variant][-1], keys[i])))
            seconds[variant].append(time.perf_counter() - start)
    results = {}
    for variant in variants:
        floats = [x for x in jax.tree.leaves(chains[variant][-1]) if jnp.issubdtype(x.dtype, jnp.floating)]
        results[variant] = {
            "compile_s": compile_s[variant],
            "steps_per_s": batch * horizon / statistics.median(seconds[variant]),
            "finite": all(bool(jnp.all(jnp.isfinite(x))) for x in floats),
        }
    return results


def task_kwargs(name: str, fidelity: str, impl: str, batch: int) -> dict:
    """Arguments of ``make_task`` for one configuration."""
    if name == "cartpole":
        return {}
    kwargs: dict[str, Any] = {"fidelity": fidelity, "impl": impl}
    # MuJoCo Warp's buffers serve the whole batch: the registry sizes them (as envs.make(batch=...)).
    return {**kwargs, **envs.warp_capacity(name, kwargs, batch)}


def warp_available() -> bool:
    """Whether MJX steps with MuJoCo Warp here; imports MJX, so asked only when warp is asked for
    (a CartPole run imports no MuJoCo)."""
    from jaxpg.envs.mjx_env import warp_available as mjx_has_warp

    return mjx_has_warp()


def configurations(args: argparse.Namespace) -> list[tuple[str, str, str]]:
    """(task, fidelity, impl) triples to run; CartPole has neither fidelity nor implementation."""
    impls = [i for i in args.impl if i != "warp" or warp_available()]
    if len(impls) < len(args.impl):
        print("warp-lang is not installed: skipping impl=warp")
    out = []
    for name in args.tasks:
        if name == "cartpole":
            out.append((name, "-", "-"))
        else:
            out.extend((name, fidelity, impl) for fidelity in args.fidelity for impl in impls)
    return out


def env_table(rows: list[dict]) -> str:
    """Markdown table of the measurements."""
    header = [
        "task",
        "fidelity",
        "impl",
        "envs",
        *(f"{v} steps/s" for v in VARIANTS),
        "env / raw",
        "compile " + " / ".join(VARIANTS) + " (s)",
    ]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        r = row["results"]
        rates = [harness.rate(r[v]["steps_per_s"]) if v in r else "-" for v in VARIANTS]
        ratio = f"{r['env']['steps_per_s'] / r['raw']['steps_per_s']:.2f}" if "env" in r and "raw" in r else "-"
        compiles = " / ".join(f"{r[v]['compile_s']:.1f}" if v in r else "-" for v in VARIANTS)
        cells = [row["task"], row["fidelity"], row["impl"], str(row["envs"]), *rates, ratio, compiles]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def env_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="throughput.py env", description=ENV_DOC, formatter_class=RAW)
    parser.add_argument("--tasks", nargs="+", default=["hopper"], choices=envs.names())
    parser.add_argument("--batch-sizes", nargs="+", type=int, default=[1024])
    parser.add_argument("--fidelity", nargs="+", default=["fast"], choices=["fast", "gymnasium"])
    parser.add_argument("--impl", nargs="+", default=["jax"], choices=["jax", "warp"])
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    parser.add_argument("--horizon", type=int, default=100, help="env steps per timed call")
    parser.add_argument("--repeats", type=int, default=5, help="timed calls after a warm-up; the median counts")
    parser.add_argument("--json", metavar="PATH", help="also write the measurements as JSON")
    args = parser.parse_args(argv)

    if "warp" in args.impl and warp_available():
        import warp

        warp.config.quiet = True  # no line per compiled kernel module
    print(harness.describe(), flush=True)
    rows = []
    for name, fidelity, impl in configurations(args):
        for batch in args.batch_sizes:
            kwargs = task_kwargs(name, fidelity, impl, batch)
            results = env_measure(args.variants, name, kwargs, batch, args.horizon, args.repeats)
            for variant, r in results.items():
                print(
                    f"{name} {fidelity} {impl} envs={batch} {variant}: {harness.rate(r['steps_per_s'])} env steps/s, "
                    f"compile {r['compile_s']:.1f} s, finite={r['finite']}",
                    flush=True,
                )
            row = {"task": name, "fidelity": fidelity, "impl": impl, "envs": batch, "results": results}
            rows.append(row)

    print()
    print(env_table(rows))
    harness.write_json(args.json, rows, horizon=args.horizon, repeats=args.repeats)


# ========================================================================================== train

TRAIN_DOC = """Training throughput against raw simulation, side by side, per implementation and batch size.

For each (impl, num_envs) this measures, in a fresh process (so that peak memory is its own):
  raw    env steps/s of the simulation a training iteration needs: the same env (auto-reset
         included), batch and horizon, random actions, ``lax.scan`` over the horizon, each timed
         call continuing from the previous call's env states as training does ("raw from reset":
         every call from the same reset states, this benchmark's baseline before the benchmark record's
         section AK, where the two agreed within 1 %), timed before anything else is compiled,
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
    from jaxpg import algos, envs
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
    # before anything else, raw ran 5-8 % faster than after training (the benchmark record, section AS).
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
            cmd = [sys.executable, __file__, "train", "--single", f"{impl}:{num_envs}"]
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


# ========================================================================================== scaling

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

On the GPU machine (MuJoCo Warp is the default there), e.g. two H200s:

    python benchmarks/throughput.py scaling --task hopper --envs-per-device 16384 --horizon 32 --json scaling.json

On the CPU, with forced host devices and tiny sizes (it runs; its timings mean nothing):

    XLA_FLAGS=--xla_force_host_platform_device_count=2 JAX_PLATFORMS=cpu \\
        python benchmarks/throughput.py scaling --task cartpole --envs-per-device 8 --horizon 4 --iterations 1
"""

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


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
    import jax.numpy as jnp

    from jaxpg import envs, train
    from jaxpg import mesh as mesh_lib
    from jaxpg import rollout as rollout_lib
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
    cmd = [sys.executable, os.path.abspath(__file__), "scaling", "--single", str(devices), "--task", args.task]
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


# ========================================================================================== learner

LEARNER_DOC = """Where the learner's fixed cost goes, and what cuts it: GAE's reverse loop and the value fit's
minibatch loop, each in a few forms, timed alone on the default device.

On a GPU both loops are chains of tiny kernels (docs/benchmarks_archive.md, section AA: the card's learner
costs 15-17 ms per iteration at every batch size, half of it the value fit's 160 Adam steps).
This times, per batch size (``T = --horizon`` steps x ``--envs`` envs):

- ``gae``: ``jaxpg.returns.gae`` as a reverse ``lax.scan`` (``parallel=False``: one step per loop
  iteration; and this script's copy of it unrolled ``--unroll`` steps, which the package dropped
  after section AA) against ``parallel=True``, a ``lax.associative_scan`` (a log-depth tree of
  whole-batch operations);
- ``value fit``: ``jaxpg.value.fit_value`` with the card's settings (10 epochs x 16 minibatches of
  1024 drawn from at most 16384 samples, MLP 128x128), its minibatches gathered one per step or
  all before the loop, with Adam per parameter array or over one flattened
  vector (``optax.flatten``); and, for scale, the fit with 2x and 4x larger minibatches (half and
  a quarter of the steps: a different fit).

Every figure is the median of ``--repeats`` synchronised calls after a compiling call. The GAE
forms and the first four value-fit forms compute the same numbers (up to float rounding for the
associative scan and the flat Adam; printed: GAE's largest difference against the scan, the value
fit's final loss).

    python benchmarks/throughput.py learner --envs 256 1024 4096 16384 65536
"""


def unrolled_gae(
    rewards: jax.Array,
    values: jax.Array,
    next_values: jax.Array,
    terminated: jax.Array,
    truncated: jax.Array,
    gamma: float,
    lam: float,
    unroll: int,
) -> jax.Array:
    """Advantages ``[T, B]`` as ``jaxpg.returns.gae`` computes them sequentially (all inputs ``[T, B]``),
    its reverse ``lax.scan`` running ``unroll`` steps per loop iteration: the same numbers, another
    program (the package dropped this form after section AA found it no faster)."""
    deltas = rewards + gamma * jnp.where(terminated, 0.0, next_values) - values
    carry_on = gamma * lam * (1.0 - (terminated | truncated).astype(deltas.dtype))

    def step(next_adv: jax.Array, xs: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
        delta, c = xs
        adv = delta + c * next_adv
        return adv, adv

    return jax.lax.scan(step, jnp.zeros_like(deltas[-1]), (deltas, carry_on), reverse=True, unroll=unroll)[1]


def gae_forms(unroll: int) -> dict[str, Callable]:
    """Jitted GAE forms, each ``(rewards, values, next_values, terminated, truncated) -> advantages``."""

    def form(parallel: bool) -> Callable:
        return jax.jit(lambda r, v, nv, te, tr: returns.gae(r, v, nv, te, tr, 0.99, 0.95, parallel=parallel)[0])

    return {
        "lax.scan (the default)": form(False),
        f"lax.scan, unroll {unroll}": jax.jit(lambda *args: unrolled_gae(*args, 0.99, 0.95, unroll)),
        "associative_scan (parallel=True)": form(True),
    }


def value_fit_forms(value_fn: ValueFunction, lr: float, epochs: int, batch: int, per_epoch: int) -> dict[str, Callable]:
    """Jitted value-fit forms, each ``(params, obs [N, D], targets [N], key) -> params``: the same
    minibatches and steps (``fit_value``'s), compiled differently."""

    def library(flat: bool, rows: int = batch) -> Callable:
        def fit(params: Any, obs: jax.Array, targets: jax.Array, key: jax.Array) -> Any:
            opt = optax.flatten(optax.adam(lr)) if flat else optax.adam(lr)
            state = opt.init(params)
            return value_lib.fit_value(
                value_fn, params, state, opt, obs, targets, key, epochs, rows, samples_per_epoch=per_epoch
            )[0]

        return jax.jit(fit)

    def gathered_first(flat: bool) -> Callable:
        def fit(params: Any, obs: jax.Array, targets: jax.Array, key: jax.Array) -> Any:
            opt = optax.flatten(optax.adam(lr)) if flat else optax.adam(lr)
            n = obs.shape[0]
            subsample = 0 < per_epoch < n
            steps = max(1, per_epoch // batch) if subsample else n // batch

            def epoch_indices(k: jax.Array) -> jax.Array:  # as fit_value draws them
                if subsample:
                    return jax.random.randint(k, (steps, batch), 0, n)
                return jax.random.permutation(k, n)[: steps * batch].reshape(steps, batch)

            idx = jax.vmap(epoch_indices)(jax.random.split(key, epochs)).reshape(epochs * steps, batch)

            def step(carry: tuple, rows: tuple) -> tuple:
                p, s = carry
                grads = jax.grad(lambda q: value_lib.value_loss(value_fn, q, *rows, jnp.ones_like(rows[1])))(p)
                updates, s = opt.update(grads, s, p)
                return (optax.apply_updates(p, updates), s), None

            return jax.lax.scan(step, (params, opt.init(params)), (obs[idx], targets[idx]))[0][0]

        return jax.jit(fit)

    return {
        "fit_value: one gather per step": library(False),
        "minibatches gathered first": gathered_first(False),
        "fit_value, Adam on one flat vector": library(True),
        "gathered first, flat Adam": gathered_first(True),
        # not the same fit: half and a quarter of the steps on 2x and 4x larger minibatches
        f"fit_value, minibatches of {2 * batch} (half the steps)": library(False, 2 * batch),
        f"fit_value, minibatches of {4 * batch} (a quarter of the steps)": library(False, 4 * batch),
    }


def learner_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="throughput.py learner", description=LEARNER_DOC, formatter_class=RAW)
    parser.add_argument("--envs", type=int, nargs="+", default=[256, 1024, 4096])
    parser.add_argument("--horizon", type=int, default=64)
    parser.add_argument("--obs-dim", type=int, default=11, help="Hopper's 11")
    parser.add_argument("--unroll", type=int, default=16)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args(argv)

    value_fn = ValueFunction(hidden=(128, 128))
    fits = value_fit_forms(value_fn, 1e-3, epochs=10, batch=1024, per_epoch=16384)
    gaes = gae_forms(args.unroll)
    rows = []
    for num_envs in args.envs:
        k = jax.random.split(jax.random.PRNGKey(num_envs), 6)
        shape = (args.horizon, num_envs)
        rewards = jax.random.normal(k[0], shape)
        values = jax.random.normal(k[1], shape)
        next_values = jax.random.normal(k[2], shape)
        terminated = jax.random.uniform(k[3], shape) < 0.01
        truncated = jax.random.uniform(k[4], shape) < 0.002
        ref = None
        for name, fn in gaes.items():
            first, med, out = harness.time_call(
                fn, rewards, values, next_values, terminated, truncated, repeats=args.repeats
            )
            ref = out if ref is None else ref
            rows.append(("gae", num_envs, name, first, med, float(jnp.max(jnp.abs(out - ref)))))
            print(rows[-1], flush=True)
        obs = jax.random.normal(k[5], (args.horizon * num_envs, args.obs_dim))
        targets = jnp.tanh(obs[:, 0]) + 0.1 * obs[:, 1]
        params = value_fn.init(jax.random.PRNGKey(1), args.obs_dim)
        ref = None
        for name, fn in fits.items():
            first, med, out = harness.time_call(fn, params, obs, targets, jax.random.PRNGKey(2), repeats=args.repeats)
            loss = float(value_lib.value_loss(value_fn, out, obs, targets))
            rows.append(("value fit", num_envs, name, first, med, loss))
            print(rows[-1], flush=True)

    keys = ("phase", "envs", "form", "first_call_s", "median_s", "check")
    harness.write_json(args.json, [dict(zip(keys, row, strict=True)) for row in rows], horizon=args.horizon)
    print(f"\n{harness.describe()}, horizon {args.horizon}, median of {args.repeats} calls")
    print("| phase | envs | form | first call s | median ms | check |")
    print("|---|---|---|---|---|---|")
    for phase, num_envs, name, first, med, check in rows:
        what = f"max diff {check:.1e}" if phase == "gae" else f"final loss {check:.4f}"
        print(f"| {phase} | {num_envs} | {name} | {first:.2f} | {med * 1e3:.2f} | {what} |")


# ========================================================================================== eval

EVAL_DOC = """What one mean-policy evaluation costs, per MJX implementation and device, with and without
stopping once every episode has ended.

A run's evaluation is ``eval_envs`` episodes of up to 1000 sequential env steps (``jaxpg.train.
evaluate_state``). At 16 envs a MuJoCo Warp step is a chain of small kernels, so the evaluation
costs about as much at 16 episodes as at 64 and is a fixed cost of every run (BENCHMARKS.md).
This times the evaluation of one policy, the mean policy from fresh resets as a run evaluates it
(``rollout.episode_totals_from``), each figure the median of ``--repeats`` synchronised calls
after the compiling one:

  early stop   as runs evaluate: the loop stops within 50 steps of the last episode's end;
  full         every episode stepped to the time limit (one chunk of 1000 steps: the work of the
               evaluation before it could stop early);

and the mean return and length reached (with the early stop, and the full evaluation's return),
so that a faster implementation or device can be checked to score the policy alike. The two
forms compute the same numbers (tested on the CPU); on a GPU MuJoCo Warp's steps are not
bit-reproducible from one program to another, so a hopping policy's 1000-step returns differ in
the last digits or more (docs/benchmarks_archive.md, sections AC and AP).

    python benchmarks/throughput.py eval RUN_DIR --impl warp jax --device default cpu --episodes 16 64
    python benchmarks/throughput.py eval --impl warp --episodes 16     # a fresh policy: episodes end early

Without ``RUN_DIR`` a freshly initialised policy of ``--task`` is evaluated (for Hopper the
``hopper`` preset's networks). On the CPU, small: ``--task inverted_pendulum --episodes 2
--impl jax``.
"""


def policy_to_evaluate(run_dir: str | None, task: str) -> tuple[str, dict[str, Any], Any, Any, Any]:
    """``(task, env_kwargs, policy, params, obs_stats)`` of ``run_dir``'s latest checkpoint, or of
    a fresh NPG policy for ``task`` (its ``hopper`` preset's networks for Hopper)."""
    if run_dir:
        from jaxpg.run.checkpoints import policy_io

        loaded = policy_io.load_policy(run_dir)
        return loaded.run.task, dict(loaded.run.env_kwargs), loaded.policy, loaded.params, loaded.obs_stats
    from jaxpg import envs
    from jaxpg.algos import npg

    env = envs.make(task)
    overrides = npg.PRESETS["hopper"] if task == "hopper" else {}
    ts = npg.init(jax.random.PRNGKey(0), env, npg.Config(**overrides))
    return task, {}, ts.policy, ts.params, ts.obs_stats


def evaluation(env: Any, policy: Any, episodes: int, check_every: int) -> Any:
    """The jitted ``(params, obs_stats, key) -> {return, length, task_score}`` (``[episodes]``
    each) of the mean policy from fresh resets, checking every ``check_every`` steps whether all
    have ended."""
    from jaxpg import rollout as rollout_lib
    from jaxpg.algos.core import make_act

    horizon = int(env.max_episode_steps)

    def run(params: Any, obs_stats: Any, key: jax.Array) -> dict[str, jax.Array]:
        reset_key, steps_key = jax.random.split(key)
        state = rollout_lib.reset_batch(env, reset_key, episodes)
        act = make_act(policy, obs_stats, deterministic=True)
        return rollout_lib.episode_totals_from(env, act, params, state, steps_key, horizon, check_every)

    return jax.jit(run)


def eval_measure(
    task: str,
    env_kwargs: dict[str, Any],
    policy: Any,
    params: Any,
    obs_stats: Any,
    impl: str,
    device: str,
    episodes: int,
    repeats: int,
) -> dict[str, Any]:
    """One row: compile and median evaluation seconds of ``episodes`` episodes with ``impl`` on
    ``device`` (``"default"`` or ``"cpu"``), with the early stop and without, and the episodes'
    mean return and length."""
    from jaxpg import envs

    target = jax.devices("cpu")[0] if device == "cpu" else jax.devices()[0]
    env = envs.make(task, **{**env_kwargs, "impl": impl})
    horizon = int(env.max_episode_steps)
    with jax.default_device(target):
        params_here, stats_here = jax.device_put((params, obs_stats), target)
        early = evaluation(env, policy, episodes, 50)
        full = evaluation(env, policy, episodes, horizon)
        compile_s, early_s, out = harness.time_calls(
            lambda i: early(params_here, stats_here, jax.random.PRNGKey(i)), repeats
        )
        out = jax.device_get(out)
        _, full_s, out_full = harness.time_calls(
            lambda i: full(params_here, stats_here, jax.random.PRNGKey(i)), repeats
        )
        out_full = jax.device_get(out_full)
    return {
        "task": task,
        "impl": impl,
        "device": target.device_kind if device != "cpu" else "cpu",
        "episodes": episodes,
        "horizon": horizon,
        "compile_s": compile_s,
        "eval_s": early_s,
        "eval_full_s": full_s,
        "ms_per_step": 1e3 * full_s / horizon,
        "return_mean": float(np.mean(out["return"])),
        "return_std": float(np.std(out["return"])),
        "return_full_mean": float(np.mean(out_full["return"])),
        "length_mean": float(np.mean(out["length"])),
        "length_max": float(np.max(out["length"])),
    }


def eval_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="throughput.py eval", description=EVAL_DOC, formatter_class=RAW)
    parser.add_argument("run_dir", nargs="?", help="a training run (default: a fresh policy of --task)")
    parser.add_argument("--task", default="hopper", help="without RUN_DIR: the task (default: hopper)")
    parser.add_argument("--impl", nargs="+", default=["warp", "jax"], choices=("warp", "jax"))
    parser.add_argument("--device", nargs="+", default=["default"], choices=("default", "cpu"))
    parser.add_argument("--episodes", nargs="+", type=int, default=[16])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args(argv)
    task, env_kwargs, policy, params, obs_stats = policy_to_evaluate(args.run_dir, args.task)
    rows = []
    for device in args.device:
        for impl in args.impl:
            if impl == "warp" and device == "cpu":
                continue
            for episodes in args.episodes:
                row = eval_measure(task, env_kwargs, policy, params, obs_stats, impl, device, episodes, args.repeats)
                rows.append(row)
                print(f"# {json.dumps(row)}", flush=True)
    harness.write_json(args.json, rows)
    print(f"\n{task} {env_kwargs or ''}, {args.run_dir or 'fresh policy'}, median of {args.repeats} evaluations")
    print(
        "| impl | device | episodes | compile s | one evaluation s (early stop) | full s | ms per env step (full) "
        "| mean return | full: mean return | mean / max length |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['impl']} | {r['device']} | {r['episodes']} | {r['compile_s']:.1f} | {r['eval_s']:.3f} "
            f"| {r['eval_full_s']:.3f} | {r['ms_per_step']:.2f} | {r['return_mean']:.1f} ± {r['return_std']:.1f} "
            f"| {r['return_full_mean']:.1f} | {r['length_mean']:.0f} / {r['length_max']:.0f} |"
        )


# ========================================================================================== host

HOST_DOC = """The host's work after each block of a run of many seeds, which the device waits for.

After each block (``--log-every`` iterations) the training process writes one ``metrics.jsonl``
record per iteration and seed and the same scalars to TensorBoard, redraws ``curves.png`` at
checkpoints and writes checkpoints. From synthetic metrics of ``--seeds`` seeds (``--keys``
scalars each, a block of ``--block`` iterations) this times, median of ``--repeats``:

  records   ``metrics_log.block_records`` to the sinks ``JsonlLog`` and ``TensorBoardLog`` (one
            event per iteration and seed, the block's checksums computed together);
  per_scalar  the same TensorBoard scalars as one event each, checksummed one by one (the writer
            before 2026-11-29), JSON included;
  curves    ``curves.png`` redrawn from the curves kept in memory after ``--iterations`` iterations;
  reread    the same redraw from ``metrics.jsonl`` re-read (before 2026-11-29, at every checkpoint);
  checkpoint  one checkpoint of a real training state (``--state TASK:ALGO:PRESET``, built with MJX's
            JAX implementation; off by default: building it compiles the task's reset).

    python benchmarks/throughput.py host --seeds 32 --iterations 12500 --state humanoid:a2c:humanoid_1m
"""


def host_main(argv: Sequence[str]) -> None:
    import shutil
    import tempfile
    from pathlib import Path

    from jaxpg.run.checkpoints import checkpointer
    from jaxpg.run.outputs import metrics_log, plotting, tensorboard

    parser = argparse.ArgumentParser(prog="throughput.py host", description=HOST_DOC, formatter_class=RAW)
    parser.add_argument("--seeds", type=int, default=32)
    parser.add_argument("--keys", type=int, default=22, help="scalars per record besides iteration and seed")
    parser.add_argument("--block", type=int, default=10, help="iterations per block")
    parser.add_argument("--iterations", type=int, default=12500, help="iterations drawn in curves.png")
    parser.add_argument("--state", help="TASK:ALGO:PRESET whose training state one checkpoint saves")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    names = [*plotting.CURVE_KEYS, *(f"metric_{i}" for i in range(args.keys - len(plotting.CURVE_KEYS)))]
    seeds = list(range(args.seeds))

    def block(n: int) -> dict[str, np.ndarray]:
        return {k: rng.normal(size=(n, args.seeds)).astype(np.float32) for k in names}

    work = Path(tempfile.mkdtemp(prefix="jaxpg-host-"))
    (work / "run").mkdir()
    writers = [metrics_log.JsonlLog(work / "run"), tensorboard.TensorBoardLog(work / "run", seeds)]
    per_scalar = [tensorboard.EventWriter(work / "old" / f"seed_{s}") for s in seeds]
    metrics = block(args.block)

    def write_records() -> None:
        records = metrics_log.block_records(metrics, 0, seeds, [0.0] * args.block)
        for writer in writers:
            writer.write(records)

    def write_per_scalar() -> None:
        for r in metrics_log.block_records(metrics, 0, seeds, [0.0] * args.block):
            json.dumps(r)
            for k, v in r.items():
                if k not in ("iteration", "seed") and v is not None:
                    per_scalar[r["seed"]].add_scalar(k, v, r["iteration"])

    history = plotting.CurveHistory()
    long_run = block(args.iterations)
    history.add_block(long_run, 0)
    (work / "long").mkdir()
    with (work / "long" / "metrics.jsonl").open("w") as f:
        for start in range(0, args.iterations, 500):
            part = {k: v[start : start + 500] for k, v in long_run.items()}
            for r in metrics_log.block_records(part, start, seeds, [0.0] * len(part[names[0]])):
                f.write(json.dumps(r) + "\n")
    png = work / "curves.png"
    calls = {
        "records": write_records,
        "per_scalar": write_per_scalar,
        "curves": lambda: plotting.plot_runs([("run", history)], png),
        "reread": lambda: plotting.plot_runs([("run", metrics_log.read_metrics(work / "long"))], png),
    }
    if args.state:
        from jaxpg import algos, train

        task, algo, preset = args.state.split(":")
        env = envs.make(task, impl="jax", **algos.preset_env_kwargs(algo, preset))
        module = algos.get(algo)
        state = train.init_seeds(module.init, seeds, env, module.Config(**algos.preset(algo, preset, task)))
        (work / "checkpoints").mkdir()
        saver = checkpointer.Checkpointer(work / "checkpoints", keep=2)
        step = [0]

        def save() -> None:
            step[0] += 1
            saver.save(step[0], state, score=0.0, metrics={}, info={})

        calls["checkpoint"] = save
    rows = []
    for name, call in calls.items():
        call()  # the first call imports matplotlib, opens files
        times = []
        for _ in range(args.repeats if name not in ("reread",) else max(1, min(args.repeats, 2))):
            t0 = time.perf_counter()
            call()
            times.append(time.perf_counter() - t0)
        rows.append({"work": name, "seconds": statistics.median(times), "repeats": len(times)})
        print(f"# {json.dumps(rows[-1])}", flush=True)
    for writer in writers:
        writer.close()
    for old in per_scalar:
        old.close()
    shutil.rmtree(work, ignore_errors=True)
    harness.write_json(args.json, rows, seeds=args.seeds, keys=args.keys, block=args.block, iterations=args.iterations)
    print(f"\n{harness.describe()}; {args.seeds} seeds, {args.keys} scalars, blocks of {args.block} iterations")
    columns = [("host work", lambda r: r["work"]), ("seconds (median)", lambda r: f"{r['seconds']:.3f}")]
    print(harness.table(rows, columns))


MODES = {
    "env": env_main,
    "train": train_main,
    "scaling": scaling_main,
    "learner": learner_main,
    "eval": eval_main,
    "host": host_main,
}


if __name__ == "__main__":
    harness.run_modes(__file__, MODES, __doc__)
