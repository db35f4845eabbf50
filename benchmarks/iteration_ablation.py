"""What each phase of an NPG iteration costs inside the whole compiled iteration, and what a change saves.

Timing phases alone (``experiments/hopper.py --profile``, ``benchmarks/learner_kernels.py``) misses
how they behave inside the training program, and comparing whole-iteration throughput across
machines cannot resolve a few percent (BENCHMARKS.md, sections AF and AH). This compiles, in one
process, the card's NPG iteration (``npg`` preset ``hopper`` at ``--num-envs``) cut after each
phase, and the whole iteration with each change in ``--changes``, each as a ``lax.scan`` of
``--iterations`` iterations (one compiled call, as ``jaxpg.train`` runs them), then times them
in interleaved rounds (every variant once per round, ``--rounds`` rounds, each call synchronised
and chained on its own outputs), so that drifts of the machine hit every variant alike;
``--order grouped`` times each variant's calls back to back instead (``--order interleaved
grouped``: both, one after the other, from the same compiled programs), as a training loop
repeats one program (on one machine both orders gave the same rollouts: BENCHMARKS.md, AO).

Variants, cumulative (each keeps what it computes alive, so that nothing is eliminated):

  sample      the rollout (NPG's phase ``sampling``): policy and physics for ``horizon`` steps;
  +advantages value predictions and GAE (``advantages``);
  +policy     the gradient, the conjugate-gradient natural step and the KL backtracking
              (``gradient``, ``natural_step``, ``kl_backoff``);
  full        ``npg.update`` as it is (adds the value fit and the iteration's bookkeeping);

The cumulative variants are NPG's own iteration (``npg.iteration``) stopped after a phase
(``cut_after``), not a copy of it.

and changes of the full iteration (``--changes``):

  gae_parallel  GAE as an associative scan (``core.gae_advantages`` with ``parallel=True``, via ``npg.make_update``);
  vmb8          ``value_minibatches=8`` (half the value fit's Adam steps; a different fit);
  unroll        the rollout alone: ``raw`` (uniform random actions in place of the policy, the
                baseline of train/raw), and ``raw`` and ``sample`` with 4 env steps per
                iteration of the rollout's loop (``rollout(..., unroll=4)``; the same numbers);
  carry         ``raw``, and ``raw_env``: the same work with ``train_throughput.py``'s loop, whose
                scan over iterations carries the env state and a key instead of the whole
                ``TrainState`` (BENCHMARKS.md AO: the two scripts' raw programs differ by 6 %).

Prints per batch size the median ms per iteration of every variant, the difference to the
previous cumulative variant (the phase's cost in context) or to ``full`` (a change's saving),
and env steps/s.

    python benchmarks/iteration_ablation.py --num-envs 1024 4096 --iterations 10 --rounds 5
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import statistics
import time
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from jaxpg import rollout as rollout_lib
from jaxpg.algos import core, npg

PHASES = ("sample", "+advantages", "+policy", "full")
CHANGES = ("gae_parallel", "vmb8", "unroll", "carry")
UNROLL = 4  # env steps per loop iteration of the rollout in the ``unroll`` rows
PARALLEL_GAE = functools.partial(core.gae_advantages, parallel=True)  # GAE as an associative scan


class _Cut(Exception):
    """Raised while tracing, after the phase an ablation stops at, carrying what it returned."""

    def __init__(self, outputs: Any) -> None:
        super().__init__()
        self.outputs = outputs


def cut_after(last_phase: str) -> Callable:
    """``ts -> (ts, metrics)``: NPG's own iteration (``npg.iteration``) stopped after its phase
    ``last_phase`` (one of ``npg.PHASES``): the phases run as ``update`` runs them, and every
    floating output of the last one is summed into the metrics, so that nothing it computes is
    eliminated. The state returned is the last one a phase returned (the sampler's, carrying the
    env state on, until the value fit)."""
    if last_phase not in npg.PHASES:
        raise ValueError(f"{last_phase!r} is not one of NPG's phases {npg.PHASES}")

    def iteration(ts: core.TrainState) -> tuple[core.TrainState, dict[str, jax.Array]]:
        latest = [ts]

        def run_phase(name: str, fn: Callable, *args: Any) -> Any:
            out = fn(*args)
            first = out[0] if isinstance(out, tuple) else out
            if isinstance(first, core.TrainState):
                latest.append(first)
            if name == last_phase:
                raise _Cut(out)
            return out

        try:
            return npg.iteration(ts, run_phase)
        except _Cut as cut:
            leaves = [x for x in jax.tree.leaves(cut.outputs) if jnp.issubdtype(jnp.asarray(x).dtype, jnp.floating)]
            return latest[-1], {"kept": sum(jnp.sum(x) for x in leaves)}

    iteration.__name__ = f"npg_through_{last_phase}"
    return iteration


sample_only = cut_after("sampling")


def uniform_act(action_size: int) -> rollout_lib.ActFn:
    """``act(params, obs [B, obs_dim], key) -> (action [B, action_size], 0 [B])``: uniform random
    actions in [-1, 1], the policy ignored (raw simulation)."""

    def act(params: Any, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        del params
        action = jax.random.uniform(key, (obs.shape[0], action_size), minval=-1.0, maxval=1.0)
        return action, jnp.zeros(obs.shape[0])

    return act


def rollout_only(policy: bool, unroll: int = 1) -> Callable:
    """The rollout's env steps (continuing sampling, one device), ``unroll`` per loop iteration,
    acting with the policy as ``core.phase_sample`` does, or with uniform random actions in its
    place (``policy=False``: what ``train_throughput.py`` calls raw simulation)."""

    def iteration(ts: core.TrainState) -> tuple[core.TrainState, dict[str, jax.Array]]:
        key, step_key = jax.random.split(ts.key)
        random_act = uniform_act(ts.env.action_size)
        act, params = (core.make_act(ts.policy, ts.obs_stats), ts.params) if policy else (random_act, None)
        env = core.sampler_env(ts.env, ts.config)
        env_state, traj = rollout_lib.rollout(
            env, act, params, ts.env_state, step_key, ts.config.horizon, unroll=unroll
        )
        return ts.replace(key=key, env_state=env_state), {"reward": jnp.sum(traj.rewards)}

    return iteration


def raw_env_block(iterations: int) -> Callable:
    """``rollout_only(policy=False)``'s work with ``train_throughput.py``'s loop structure: the scan
    over iterations carries only the env state and a key, not the whole ``TrainState`` (which
    goes in and out of the call around it)."""

    def block(ts: core.TrainState) -> tuple[core.TrainState, dict[str, jax.Array]]:
        random_act = uniform_act(ts.env.action_size)
        env = core.sampler_env(ts.env, ts.config)

        def one(carry: tuple, _: None) -> tuple[tuple, jax.Array]:
            env_state, key = carry
            key, step_key = jax.random.split(key)
            env_state, traj = rollout_lib.rollout(env, random_act, None, env_state, step_key, ts.config.horizon)
            return (env_state, key), jnp.sum(traj.rewards)

        (env_state, key), rewards = jax.lax.scan(one, (ts.env_state, ts.key), None, length=iterations)
        return ts.replace(env_state=env_state, key=key), {"reward": rewards}

    return block


def variants(changes: list[str]) -> dict[str, tuple[Callable | None, dict[str, Any]]]:
    """Name -> (update function, config overrides) of every variant timed."""
    table: dict[str, tuple[Callable | None, dict[str, Any]]] = {
        "sample": (sample_only, {}),
        "+advantages": (cut_after("advantages"), {}),
        "+policy": (cut_after("kl_backoff"), {}),
        "full": (npg.update, {}),
    }
    if "gae_parallel" in changes:
        table["gae_parallel"] = (npg.make_update(PARALLEL_GAE), {})
    if "vmb8" in changes:
        table["vmb8"] = (npg.update, {"value_minibatches": 8})
    if "unroll" in changes or "carry" in changes:
        table["raw"] = (rollout_only(policy=False), {})
    if "carry" in changes:
        table["raw_env"] = (None, {})  # built by raw_env_block: not a per-iteration update
    if "unroll" in changes:
        table[f"raw_u{UNROLL}"] = (rollout_only(policy=False, unroll=UNROLL), {})
        table[f"sample_u{UNROLL}"] = (rollout_only(policy=True, unroll=UNROLL), {})
    return table


def measure(
    num_envs: int,
    iterations: int,
    rounds: int,
    changes: list[str],
    task: str = "hopper",
    orders: tuple[str, ...] = ("interleaved",),
) -> list[dict[str, Any]]:
    """One batch size: compile every variant, then, for each of ``orders``, time them in
    interleaved rounds (``"interleaved"``) or each variant's ``rounds`` calls back to back
    (``"grouped"``); one row per order."""
    from jaxpg import envs
    from jaxpg import train as train_lib

    env = envs.make(task, batch=num_envs)
    base = npg.Config(**{**npg.PRESETS["hopper"], "num_envs": num_envs})
    device = jax.devices()[0]
    states, blocks, compile_s = {}, {}, {}
    for name, (update, overrides) in variants(changes).items():
        config = dataclasses.replace(base, **overrides)
        ts = jax.device_put(npg.init(jax.random.PRNGKey(0), env, config), device)
        if update is None:
            block = jax.jit(raw_env_block(iterations))
        else:
            block = jax.jit(lambda t, u=update: train_lib.scan_updates(u, t, iterations))
        start = time.perf_counter()
        ts, _ = jax.block_until_ready(block(ts))
        compile_s[name] = time.perf_counter() - start
        ts, _ = jax.block_until_ready(block(ts))  # once more on the call's own outputs
        states[name], blocks[name] = ts, block
        print(f"  {num_envs} envs: {name} compiled in {compile_s[name]:.1f} s", flush=True)
    rows = []
    for order in orders:
        times: dict[str, list[float]] = {name: [] for name in blocks}

        def timed_call(name: str, times: dict[str, list[float]] = times) -> None:
            start = time.perf_counter()
            states[name], _ = jax.block_until_ready(blocks[name](states[name]))
            times[name].append((time.perf_counter() - start) / iterations)

        if order == "interleaved":  # every variant once per round: all see the machine alike
            for _ in range(rounds):
                for name in blocks:
                    timed_call(name)
        else:  # "grouped": each variant's calls back to back, as a training loop repeats one program
            for name in blocks:
                for _ in range(rounds):
                    timed_call(name)
        rows.append(
            {
                "task": task,
                "num_envs": num_envs,
                "horizon": base.horizon,
                "iterations": iterations,
                "rounds": rounds,
                "order": order,
                "ms_per_iteration": {name: 1e3 * statistics.median(t) for name, t in times.items()},
                "spread_ms": {name: 1e3 * (max(t) - min(t)) for name, t in times.items()},
                "compile_s": compile_s,
                "device": device.device_kind,
            }
        )
    return rows


def print_table(row: dict[str, Any]) -> None:
    """The variants of one batch size as a markdown table."""
    ms, spread = row["ms_per_iteration"], row["spread_ms"]
    samples = row["num_envs"] * row["horizon"]
    print(
        f"\n{row['num_envs']} envs x {row['horizon']} steps, {row['iterations']} iterations per call, "
        f"median of {row['rounds']} {row.get('order', 'interleaved')} calls per variant, {row['device']}"
    )
    print("| variant | ms / iteration (spread) | difference | env steps/s | compile s |")
    print("|---|---|---|---|---|")
    previous = None
    for name in ms:
        if name in PHASES:
            diff = "" if previous is None else f"{ms[name] - ms[previous]:+.2f} (phase)"
            previous = name
        elif name.startswith(("raw", "sample_u")):
            diff = f"{ms[name] - ms['sample']:+.2f} (vs sample)"
        else:
            diff = f"{ms[name] - ms['full']:+.2f} (vs full)"
        print(
            f"| {name} | {ms[name]:.2f} ({spread[name]:.2f}) | {diff} | {samples / ms[name] * 1e3 / 1e6:.3f} M "
            f"| {row['compile_s'][name]:.1f} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--num-envs", type=int, nargs="+", default=[1024, 4096])
    parser.add_argument("--iterations", type=int, default=10, help="iterations per compiled call")
    parser.add_argument("--rounds", type=int, default=5, help="timed calls per variant")
    parser.add_argument("--changes", nargs="*", default=list(CHANGES), choices=CHANGES)
    parser.add_argument(
        "--order",
        nargs="+",
        default=["interleaved"],
        choices=("interleaved", "grouped"),
        help="time the variants in interleaved rounds (default) and/or each one's calls back to back",
    )
    parser.add_argument("--task", default="hopper", help="another env for a quick check (the preset is Hopper's)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    if args.iterations < 1 or args.rounds < 1:
        parser.error("--iterations and --rounds must be >= 1")
    rows = []
    for num_envs in args.num_envs:
        for row in measure(num_envs, args.iterations, args.rounds, args.changes, args.task, tuple(args.order)):
            rows.append(row)
            print_table(row)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
