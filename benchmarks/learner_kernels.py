"""Where the learner's fixed cost goes, and what cuts it: GAE's reverse loop and the value fit's
minibatch loop, each in a few forms, timed alone on the default device.

On a GPU both loops are chains of tiny kernels (BENCHMARKS.md, section AA: the card's learner
costs 15-17 ms per iteration at every batch size, half of it the value fit's 160 Adam steps).
This times, per batch size (``T = --horizon`` steps x ``--envs`` envs):

- ``gae``: ``jaxpg.returns.gae`` as a reverse ``lax.scan`` (``parallel=False``: one step per loop
  iteration, and unrolled ``--unroll`` steps) against ``parallel=True``, a ``lax.associative_scan`` (a
  log-depth tree of whole-batch operations);
- ``value fit``: ``jaxpg.value.fit_value`` with the card's settings (10 epochs x 16 minibatches of
  1024 drawn from at most 16384 samples, MLP 128x128), its minibatches gathered one per step or
  all before the loop, with Adam per parameter array or over one flattened
  vector (``optax.flatten``); and, for scale, the fit with 2x and 4x larger minibatches (half and
  a quarter of the steps: a different fit).

Every figure is the median of ``--repeats`` synchronised calls after a compiling call. The GAE
forms and the first four value-fit forms compute the same numbers (up to float rounding for the
associative scan and the flat Adam; printed: GAE's largest difference against the scan, the value
fit's final loss).

    python benchmarks/learner_kernels.py --envs 256 1024 4096 16384 65536
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import optax

from jaxpg import returns
from jaxpg import value as value_lib
from jaxpg.policies import ValueFunction

# A sibling script's timer: the first call's time (compilation), then the median of synchronised calls.
sys.path.insert(0, str(Path(__file__).resolve().parent))
from train_throughput import time_call  # noqa: E402


def gae_forms(unroll: int) -> dict[str, Callable]:
    """Jitted GAE forms, each ``(rewards, values, next_values, terminated, truncated) -> advantages``."""

    def form(parallel: bool, u: int = 1) -> Callable:
        return jax.jit(
            lambda r, v, nv, te, tr: returns.gae(r, v, nv, te, tr, 0.99, 0.95, unroll=u, parallel=parallel)[0]
        )

    return {
        "lax.scan (the default)": form(False),
        f"lax.scan, unroll {unroll}": form(False, unroll),
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--envs", type=int, nargs="+", default=[256, 1024, 4096])
    parser.add_argument("--horizon", type=int, default=64)
    parser.add_argument("--obs-dim", type=int, default=11, help="Hopper's 11")
    parser.add_argument("--unroll", type=int, default=16)
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()

    value_fn = ValueFunction(hidden=(128, 128))
    fits = value_fit_forms(value_fn, 1e-3, epochs=10, batch=1024, per_epoch=16384)
    gaes = gae_forms(args.unroll)
    rows = []
    for envs in args.envs:
        k = jax.random.split(jax.random.PRNGKey(envs), 6)
        shape = (args.horizon, envs)
        rewards = jax.random.normal(k[0], shape)
        values = jax.random.normal(k[1], shape)
        next_values = jax.random.normal(k[2], shape)
        terminated = jax.random.uniform(k[3], shape) < 0.01
        truncated = jax.random.uniform(k[4], shape) < 0.002
        ref = None
        for name, fn in gaes.items():
            first, med, out = time_call(fn, rewards, values, next_values, terminated, truncated, repeats=args.repeats)
            ref = out if ref is None else ref
            rows.append(("gae", envs, name, first, med, float(jnp.max(jnp.abs(out - ref)))))
            print(rows[-1], flush=True)
        obs = jax.random.normal(k[5], (args.horizon * envs, args.obs_dim))
        targets = jnp.tanh(obs[:, 0]) + 0.1 * obs[:, 1]
        params = value_fn.init(jax.random.PRNGKey(1), args.obs_dim)
        ref = None
        for name, fn in fits.items():
            first, med, out = time_call(fn, params, obs, targets, jax.random.PRNGKey(2), repeats=args.repeats)
            loss = float(value_lib.value_loss(value_fn, out, obs, targets))
            rows.append(("value fit", envs, name, first, med, loss))
            print(rows[-1], flush=True)

    device = jax.devices()[0].device_kind
    print(f"\n{device}, JAX {jax.__version__}, horizon {args.horizon}, median of {args.repeats} calls")
    print("| phase | envs | form | first call s | median ms | check |")
    print("|---|---|---|---|---|---|")
    for phase, envs, name, first, med, check in rows:
        what = f"max diff {check:.1e}" if phase == "gae" else f"final loss {check:.4f}"
        print(f"| {phase} | {envs} | {name} | {first:.2f} | {med * 1e3:.2f} | {what} |")


if __name__ == "__main__":
    main()
