"""``throughput.py learner``: GAE and the value fit in several equivalent forms, timed alone."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from typing import Any

import harness
import jax
import jax.numpy as jnp
import optax

from jaxpg import returns
from jaxpg import value as value_lib
from jaxpg.policies import ValueFunction

RAW = argparse.RawDescriptionHelpFormatter


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
