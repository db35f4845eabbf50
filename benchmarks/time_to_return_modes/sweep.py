"""``time_to_return.py sweep``: sample efficiency of named NPG settings on Hopper at the command line's batch."""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
from collections.abc import Sequence
from typing import Any

import harness

RAW = argparse.RawDescriptionHelpFormatter


SWEEP_DOC = """Sample efficiency of NPG settings on Hopper at the command line's batch (256 envs).

Each named setting trains several seeds together (``vmap``) for ``--steps`` env steps, and the
mean (deterministic) policy of every seed is evaluated on ``--eval-envs`` fresh episodes at each
mark of ``--marks`` (millions of env steps) by a separately jitted evaluation, outside the training
program. Prints one row per setting: the mean-policy return of each seed at each mark, the
training time after compilation and the compilation time.

    python benchmarks/time_to_return.py sweep --settings base step07 h32 --seeds 0 1 2 --steps 2e6 \
        --marks 1 1.5 2 --json sweep.json
"""

# The starting point: 256 envs x 64 steps, normalised step 0.05, observation normalisation,
# initial log-std -0.5, value 128x128 fitted for 3 epochs in minibatches of 1024.
BASE: dict[str, Any] = dict(
    num_envs=256,
    horizon=64,
    kl_delta=0.05,
    normalize_observations=True,
    log_std_init=-0.5,
    value_hidden=(128, 128),
    value_epochs=3,
    value_batch_size=1024,
    eval_envs=0,
)

SETTINGS: dict[str, dict[str, Any]] = {
    "base": {},
    "step07": dict(kl_delta=0.07),
    "step10": dict(kl_delta=0.1),
    "h32": dict(horizon=32),
    "h32s035": dict(horizon=32, kl_delta=0.035),
    "h32s07": dict(horizon=32, kl_delta=0.07),
    "vep10": dict(value_epochs=10),
    "vep10lr3": dict(value_epochs=10, value_lr=3e-3),
    "g99": dict(gamma=0.99, gae_lambda=0.95),
    "g99l97": dict(gamma=0.99),
    "std1": dict(log_std_init=-1.0),
    "pol32": dict(policy_hidden=(32, 32)),
    "damp01": dict(cg_damping=0.1),
    "step07vep10": dict(kl_delta=0.07, value_epochs=10),
    "h32vep10": dict(horizon=32, value_epochs=10),
    "vb256": dict(value_batch_size=256),
    "cg20": dict(cg_iters=20),
    "s07g99": dict(kl_delta=0.07, gamma=0.99, gae_lambda=0.95),
    "s07std1": dict(kl_delta=0.07, log_std_init=-1.0),
    "s10vep10": dict(kl_delta=0.1, value_epochs=10),
    "s07vep10lr3": dict(kl_delta=0.07, value_epochs=10, value_lr=3e-3),
    # Around the command line's default (step 0.07, 10 value epochs):
    "vnorm": dict(kl_delta=0.07, value_epochs=10, normalize_value_targets=True),
    "std0": dict(kl_delta=0.07, value_epochs=10, log_std_init=0.0),
    "vnorm_std0": dict(kl_delta=0.07, value_epochs=10, normalize_value_targets=True, log_std_init=0.0),
    "lam95": dict(kl_delta=0.07, value_epochs=10, gae_lambda=0.95),
    "vnorm_s10": dict(kl_delta=0.1, value_epochs=10, normalize_value_targets=True),
    "vnorm_vep5": dict(kl_delta=0.07, value_epochs=5, normalize_value_targets=True),
    "vep20": dict(kl_delta=0.07, value_epochs=20),
}

# Settings named card* start from the command line's own preset (npg's ``hopper``) instead of BASE,
# to look for what takes every seed past 3000 within 1 M env steps (the card's stretch aim).
CARD_SETTINGS: dict[str, dict[str, Any]] = {
    "card": {},
    "card_s085": dict(kl_delta=0.085),
    "card_s10": dict(kl_delta=0.1),
    "card_h48": dict(horizon=48),
    "card_lam97": dict(gae_lambda=0.97),
    "card_g995": dict(gamma=0.995),
    "card_vep15": dict(value_epochs=15),
}
SETTINGS.update(CARD_SETTINGS)


def base_config(name: str) -> dict[str, Any]:
    """The overrides a setting starts from: the card preset (evaluation off) for ``card*``, else BASE."""
    if name in CARD_SETTINGS:
        from jaxpg.algos import npg

        return {**npg.PRESETS["hopper"], "eval_envs": 0}
    return BASE


def run_setting(
    name: str,
    overrides: dict[str, Any],
    seeds: list[int],
    steps: float,
    marks: list[float],
    eval_envs: int,
    impl: str | None,
    block: int,
) -> dict[str, Any]:
    """Train one setting for every seed at once; returns its row."""
    import jax
    import numpy as np

    from jaxpg import envs, train
    from jaxpg.algos import core, npg

    config = npg.Config(**{**base_config(name), **overrides})
    batch = max(config.num_envs, eval_envs) * len(seeds)
    env = envs.make("hopper", batch=batch, impl=impl)
    eval_config = dataclasses.replace(config, eval_envs=eval_envs)

    @jax.jit
    def evaluate(ts: Any, key: jax.Array) -> Any:
        keys = jax.random.split(key, len(seeds))
        return jax.vmap(lambda t, k: core.evaluate(t.replace(config=eval_config), k))(ts, keys)

    start = time.perf_counter()
    ts = train.init_seeds(npg.init, seeds, env, config)
    iterations = math.ceil(steps / config.samples_per_iteration)
    mark_iters = sorted(
        {min(iterations, max(block, round(m * 1e6 / config.samples_per_iteration / block) * block)) for m in marks}
        | {iterations}
    )
    step_fn = train.compiled_block(npg.update, block, True)
    done, train_s, compile_s, returns = 0, 0.0, 0.0, {}
    ts = jax.tree.map(lambda x: x.copy(), ts)
    while done < iterations:
        n = min(block, iterations - done)
        fn = step_fn if n == block else train.compiled_block(npg.update, n, True)
        t0 = time.perf_counter()
        ts, metrics = fn(ts)
        jax.block_until_ready(ts)
        dt = time.perf_counter() - t0
        if done == 0:
            compile_s = dt
        else:
            train_s += dt
        done += n
        if done in mark_iters:
            out = jax.device_get(evaluate(ts, jax.random.PRNGKey(1000 + done)))
            returns[done * config.samples_per_iteration] = [float(x) for x in np.asarray(out["episode_return"])]
            stoch = np.nanmean(np.asarray(metrics["return_stochastic"])[-1])
            print(
                f"  {name} {done * config.samples_per_iteration / 1e6:.2f} M steps: mean policy "
                f"{' / '.join(f'{r:.0f}' for r in returns[done * config.samples_per_iteration])}, "
                f"stochastic {stoch:.0f}",
                flush=True,
            )
    total = time.perf_counter() - start
    return {
        "name": name,
        "overrides": {k: list(v) if isinstance(v, tuple) else v for k, v in overrides.items()},
        "seeds": seeds,
        "iterations": iterations,
        "returns": {str(k): v for k, v in returns.items()},
        "train_s": train_s,
        "first_block_s": compile_s,
        "total_s": total,
        "steps_per_s": (iterations - block) * config.samples_per_iteration * len(seeds) / max(train_s, 1e-9),
        "impl": env.impl,
        "device": jax.devices()[0].device_kind,
    }


def sweep_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="time_to_return.py sweep", description=SWEEP_DOC, formatter_class=RAW)
    parser.add_argument("--settings", nargs="+", default=["base"], choices=sorted(SETTINGS))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--steps", type=float, default=2e6, help="env steps per seed")
    parser.add_argument("--marks", nargs="+", type=float, default=[1.0, 1.5, 2.0], help="evaluate at (M steps)")
    parser.add_argument("--eval-envs", type=int, default=16)
    parser.add_argument("--impl", choices=("jax", "warp"), default=None)
    parser.add_argument("--block", type=int, default=8, help="iterations per compiled call (lax.scan)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)

    from jaxpg.run.host import compile_cache

    compile_cache.enable()
    rows = []
    for name in args.settings:
        row = run_setting(
            name, SETTINGS[name], args.seeds, args.steps, args.marks, args.eval_envs, args.impl, args.block
        )
        rows.append(row)
        harness.write_json(args.json, rows, argv=list(argv))
    marks = " | ".join(f"@ {int(k) / 1e6:.2f} M" for k in rows[0]["returns"])
    print(f"\n| setting | overrides | {marks} | train s | first block s | env steps/s |")
    print("|---" * (5 + len(rows[0]["returns"])) + "|")
    for row in rows:
        cells = []
        for values in row["returns"].values():
            cells.append(f"{min(values):.0f} / {sum(values) / len(values):.0f}")
        print(
            f"| {row['name']} | {row['overrides']} | {' | '.join(cells)} | {row['train_s']:.1f} | "
            f"{row['first_block_s']:.1f} | {row['steps_per_s'] / 1e3:.0f} k |"
        )
    print("cells: min / mean over seeds of the mean-policy return")
