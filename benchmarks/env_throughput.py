"""Raw environment throughput: env steps/s with random actions, no policy.

Every measurement ``vmap``s over ``--batch-sizes`` envs and ``lax.scan``s over ``--horizon`` env
steps inside one jitted call, timed after compilation (compile time reported apart), for three
variants of the same task:

  raw   the physics alone: ``frame_skip`` ``mjx.step`` calls per env step on ``mjx.Data`` (CartPole:
        its dynamics function); no observation, reward, guard, wrapper or reset;
  task  the bare task's ``step``: physics plus observation, reward, termination, time limit and the
        non-finite guard;
  env   what a sampler steps: ``jaxpg.envs.make``'s wrappers (``ClipAction``, ``EpisodeStats``)
        and ``AutoReset`` on top, which computes a fresh reset state at every step.

``env / raw`` is the fraction of the simulation's speed that jaxpg's env keeps. Drawing the random
actions is part of every variant.

    python benchmarks/env_throughput.py --tasks hopper inverted_pendulum --batch-sizes 1024 4096 \\
        --fidelity fast gymnasium --impl jax warp --horizon 100 --json env_throughput.json

On the CPU, with tiny sizes: ``--tasks cartpole inverted_pendulum --batch-sizes 4 --horizon 10``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxpg import envs
from jaxpg.envs.mjx_env import MjxEnv, warp_available

VARIANTS = ("raw", "task", "env")


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
        if isinstance(task, MjxEnv):
            init_one = lambda key: task.reset(key).data
            step_one = task.physics_step
        else:  # CartPole: the dynamics on the bare state vector
            init_one = lambda key: task.reset(key).data.state
            step_one = task.dynamics
    else:
        env = task if variant == "task" else envs.AutoReset(envs.make(name, **kwargs))
        init_one, step_one = env.reset, env.step

    def init(key: jax.Array) -> Any:
        return jax.vmap(init_one)(jax.random.split(key, batch))

    def run(carry: Any, key: jax.Array) -> Any:
        def body(carry: Any, step_key: jax.Array) -> tuple[Any, None]:
            return jax.vmap(step_one)(carry, random_actions(task, step_key, batch)), None

        carry, _ = jax.lax.scan(body, carry, jax.random.split(key, horizon))
        return carry

    return jax.jit(init), jax.jit(run)


def measure(variant: str, name: str, kwargs: dict, batch: int, horizon: int, repeats: int) -> dict:
    """Compile time and env steps/s (median over ``repeats`` timed calls) of one variant."""
    init, run = make_runner(variant, name, kwargs, batch, horizon)
    carry = jax.block_until_ready(init(jax.random.key(0)))
    keys = jax.random.split(jax.random.key(1), repeats + 1)
    start = time.perf_counter()
    compiled = run.lower(carry, keys[0]).compile()
    compile_s = time.perf_counter() - start
    carry = jax.block_until_ready(compiled(carry, keys[0]))  # warm-up
    times = []
    for key in keys[1:]:
        start = time.perf_counter()
        carry = jax.block_until_ready(compiled(carry, key))
        times.append(time.perf_counter() - start)
    seconds = float(np.median(times))
    finite = all(
        bool(jnp.all(jnp.isfinite(x))) for x in jax.tree.leaves(carry) if jnp.issubdtype(x.dtype, jnp.floating)
    )
    return {"compile_s": compile_s, "steps_per_s": batch * horizon / seconds, "finite": finite}


def task_kwargs(name: str, fidelity: str, impl: str, batch: int) -> dict:
    """Arguments of ``make_task`` for one configuration."""
    if name == "cartpole":
        return {}
    kwargs: dict[str, Any] = {"fidelity": fidelity, "impl": impl}
    # MuJoCo Warp's buffers serve the whole batch: the registry sizes them (as envs.make(batch=...)).
    return {**kwargs, **envs.warp_capacity(name, kwargs, batch)}


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


def fmt_rate(x: float) -> str:
    return f"{x / 1e6:.2f} M" if x >= 1e6 else f"{x / 1e3:.1f} k" if x >= 1e3 else f"{x:.0f}"


def table(rows: list[dict]) -> str:
    """Markdown table of the measurements."""
    header = [
        "task",
        "fidelity",
        "impl",
        "envs",
        *(f"{v} steps/s" for v in VARIANTS),
        "env / raw",
        "compile raw / task / env (s)",
    ]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        r = row["results"]
        rates = [fmt_rate(r[v]["steps_per_s"]) if v in r else "-" for v in VARIANTS]
        ratio = f"{r['env']['steps_per_s'] / r['raw']['steps_per_s']:.2f}" if "env" in r and "raw" in r else "-"
        compiles = " / ".join(f"{r[v]['compile_s']:.1f}" if v in r else "-" for v in VARIANTS)
        cells = [row["task"], row["fidelity"], row["impl"], str(row["envs"]), *rates, ratio, compiles]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=["hopper"], choices=envs.names())
    parser.add_argument("--batch-sizes", nargs="+", type=int, default=[1024])
    parser.add_argument("--fidelity", nargs="+", default=["fast"], choices=["fast", "gymnasium"])
    parser.add_argument("--impl", nargs="+", default=["jax"], choices=["jax", "warp"])
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    parser.add_argument("--horizon", type=int, default=100, help="env steps per timed call")
    parser.add_argument("--repeats", type=int, default=5, help="timed calls after a warm-up; the median counts")
    parser.add_argument("--json", metavar="PATH", help="also write the measurements as JSON")
    args = parser.parse_args()

    if "warp" in args.impl and warp_available():
        import warp

        warp.config.quiet = True  # no line per compiled kernel module
    device = jax.devices()[0]
    print(f"device: {device.device_kind} ({jax.default_backend()}), jax {jax.__version__}", flush=True)
    rows = []
    for name, fidelity, impl in configurations(args):
        for batch in args.batch_sizes:
            kwargs = task_kwargs(name, fidelity, impl, batch)
            results = {}
            for variant in args.variants:
                results[variant] = r = measure(variant, name, kwargs, batch, args.horizon, args.repeats)
                print(
                    f"{name} {fidelity} {impl} envs={batch} {variant}: {fmt_rate(r['steps_per_s'])} env steps/s, "
                    f"compile {r['compile_s']:.1f} s, finite={r['finite']}",
                    flush=True,
                )
            row = {"task": name, "fidelity": fidelity, "impl": impl, "envs": batch, "results": results}
            rows.append(row)

    print()
    print(table(rows))
    if args.json:
        meta = {
            "device": device.device_kind,
            "backend": jax.default_backend(),
            "jax": jax.__version__,
            "host": platform.node(),
            "horizon": args.horizon,
            "repeats": args.repeats,
        }
        with open(args.json, "w") as f:
            json.dump({"meta": meta, "rows": rows}, f, indent=2)
        print(f"\nwrote {args.json}")


if __name__ == "__main__":
    main()
