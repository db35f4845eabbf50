"""``throughput.py env``: raw environment throughput, random actions, no policy (its doc: ``ENV_DOC``)."""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable, Sequence
from typing import Any

import harness
import jax
import jax.numpy as jnp

from jaxpg import envs

RAW = argparse.RawDescriptionHelpFormatter


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
