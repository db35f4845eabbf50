"""Pong from pixels on the accelerator: frames per second, and time for A2C to beat the opponent.

Two measurements on jaxpg's pure-JAX Pong (``experiments/pong.py``'s env: frame differences of
80x80 frames; not the Atari ROM):

  fps     frames (env steps) per second of ``--fps-envs`` games with random actions, in a jitted
          ``lax.scan`` of ``--horizon`` steps, timed after compilation; and of A2C training
          (sampling with the seed's 6400 -> 200 -> 2 network plus the update) at the same batch;
  beat    A2C (``experiments/pong.py``'s settings, but ``--lr`` 2e-3 by default: at 1024 envs
          on an H200 it did better than 4e-3, and at 2048 envs better than 1e-3) with
          ``--train-envs`` games and each of ``--seeds``, ``--lr`` and ``--t-max``, trained for at
          most ``--seconds`` of wall clock: when the seed's running reward (EMA over games of the
          final score difference) first exceeds each of ``--thresholds`` (0: the agent beats the
          scripted opponent on average; 10: by 10 points of 21). The clock starts after
          compilation, as in ``experiments/pong.py``; compilation is reported apart.

    python benchmarks/pong.py --fps-envs 1024 4096 --train-envs 1024 --seeds 0 1 2 --seconds 150 --json pong.json
    python benchmarks/pong.py --fps-envs 8 --train-envs 8 --seconds 5 --size 40     # CPU smoke run
    python benchmarks/pong.py --plot docs/pong_a2c_h200.png benchmarks/results/2026-11-22-h200/pong*.json
    python benchmarks/pong.py --fps-envs --train-envs 2048 --lr 1e-3 2e-3 4e-3 --seconds 125   # the lr sweep
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
import time
from pathlib import Path
from types import ModuleType

import jax
import jax.numpy as jnp

from jaxpg import compile_cache


def load_experiment() -> ModuleType:
    """``experiments/pong.py`` as a module (its env, configs, running reward and training loop)."""
    path = Path(__file__).resolve().parents[1] / "experiments" / "pong.py"
    spec = importlib.util.spec_from_file_location("pong_experiment", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def env_fps(pong: ModuleType, num_envs: int, horizon: int, size: int, repeats: int = 3) -> dict:
    """Frames/s of ``num_envs`` games stepped with random actions (auto-reset included)."""
    from jaxpg import envs
    from jaxpg import rollout as rollout_lib

    env = envs.AutoReset(pong.make_env(size))
    state = rollout_lib.reset_batch(env, jax.random.PRNGKey(0), num_envs)

    def random_act(params, obs, key):  # noqa: ANN001, ANN202
        del params
        return jax.random.randint(key, obs.shape[:1], 0, env.action_size), jnp.zeros(obs.shape[0])

    run = jax.jit(lambda s, k: rollout_lib.rollout(env, random_act, None, s, k, horizon)[0])
    start = time.perf_counter()
    state = jax.block_until_ready(run(state, jax.random.PRNGKey(1)))
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    for i in range(repeats):
        state = jax.block_until_ready(run(state, jax.random.PRNGKey(2 + i)))
    return {"fps": num_envs * horizon * repeats / (time.perf_counter() - start), "compile_s": compile_s}


def train_fps(pong: ModuleType, num_envs: int, size: int, per_call: int = 1, iterations: int = 24) -> dict:
    """Frames/s of A2C training iterations (sampling + update), ``per_call`` iterations per compiled
    call (a ``lax.scan``), calls dispatched without waiting."""
    from jaxpg import train as train_lib

    env = pong.make_env(size)
    config = pong.make_config("a2c", num_envs)
    init, update = pong.ALGORITHMS["a2c"]
    ts = train_lib._private_copy(init(jax.random.PRNGKey(0), env, config))
    step = train_lib.compiled_block(update, per_call, False)
    start = time.perf_counter()
    ts, _ = jax.block_until_ready(step(ts))
    compile_s = time.perf_counter() - start
    calls = max(1, iterations // per_call)
    start = time.perf_counter()
    for _ in range(calls):
        ts, _ = step(ts)
    jax.block_until_ready(ts)
    return {
        "fps": config.samples_per_iteration * per_call * calls / (time.perf_counter() - start),
        "compile_s": compile_s,
        "iterations_per_call": per_call,
    }


def time_to_beat(
    pong: ModuleType,
    num_envs: int,
    seconds: float,
    size: int,
    thresholds: list[float],
    seed: int = 0,
    call_steps: int = 2048,
    **overrides: float,
) -> dict:
    """Train A2C (``overrides`` on ``experiments/pong.py``'s settings, e.g. ``lr``, ``horizon``) for
    up to ``seconds``; wall-clock seconds and env steps at which the running reward first exceeds
    each threshold (``None`` where it never did)."""
    env = pong.make_env(size)
    config = pong.make_config("a2c", num_envs, **overrides)
    _, record, compile_s = pong.train_for(
        "a2c", env, config, seconds, seed=seed, call_steps=call_steps, log=lambda line: print(line, flush=True)
    )
    reached = {}
    for threshold in thresholds:
        first = next((r for r in record.rows if r["running_reward"] > threshold), None)
        reached[str(threshold)] = (
            None if first is None else {"seconds": first["wall_s"], "env_steps": first["env_steps"]}
        )
    last = record.rows[-1]
    curve, last_kept = [], -math.inf  # at most two points a second
    for r in record.rows:
        if r["wall_s"] - last_kept >= 0.5 or r is record.rows[-1]:
            curve.append({k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in r.items()})
            last_kept = r["wall_s"]
    return {
        "num_envs": num_envs,
        "seed": seed,
        "call_steps": call_steps,
        "lr": config.lr,
        "horizon": config.horizon,
        "compile_s": compile_s,
        "reached": reached,
        "final_running_reward": last["running_reward"],
        "games": last["games"],
        "env_steps": last["env_steps"],
        "wall_s": last["wall_s"],
        "curve": curve,
    }


def plot(json_paths: list[str], out: str) -> None:
    """Running reward against wall clock for every A2C run in the ``--json`` files, into ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs, device = [], ""
    for path in json_paths:
        with open(path) as f:
            result = json.load(f)
        runs += result["beat"]
        device = result["device"]
    settings = sorted({(r["num_envs"], r.get("horizon", 8), r.get("lr", 1e-3)) for r in runs})
    colors = dict(zip(settings, plt.get_cmap("tab10").colors, strict=False))
    fig, ax = plt.subplots(figsize=(8, 4.5))
    labelled = set()
    for run in runs:
        key = (run["num_envs"], run.get("horizon", 8), run.get("lr", 1e-3))
        label = None if key in labelled else f"A2C, {key[0]} envs, t_max {key[1]}, lr {key[2]:g}"
        labelled.add(key)
        t = [row["wall_s"] for row in run["curve"]]
        ax.plot(t, [row["running_reward"] for row in run["curve"]], color=colors.get(key), lw=1.2, label=label)
    ax.axhline(0.0, color="k", lw=0.8, ls="--")
    ax.axhline(10.0, color="k", lw=0.8, ls=":")
    ax.set_xlabel("wall-clock seconds (compilation excluded)")
    ax.set_ylabel("running reward (EMA of game score)")
    ax.set_title(f"jaxpg Pong from frame differences, {device}: one line per run (seed)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=100)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fps-envs", type=int, nargs="*", default=[1024, 4096])
    parser.add_argument("--horizon", type=int, default=128, help="env steps per timed call (fps)")
    parser.add_argument("--train-envs", type=int, nargs="*", default=[1024])
    parser.add_argument("--seconds", type=float, default=240.0, help="wall-clock budget of each A2C run")
    parser.add_argument("--lr", type=float, nargs="+", default=[2e-3], help="A2C runs for each learning rate")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0], help="A2C runs for each seed")
    parser.add_argument("--call-steps", type=int, default=2048, help="env steps per compiled call while training")
    parser.add_argument("--t-max", type=int, nargs="+", default=[8], help="A2C runs for each t_max (horizon)")
    parser.add_argument("--scan", type=int, default=8, help="also time A2C with this many iterations per call")
    parser.add_argument("--thresholds", type=float, nargs="+", default=[0.0, 10.0])
    parser.add_argument("--size", type=int, default=80)
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--plot", nargs="+", metavar=("OUT", "JSON"), help="only plot earlier --json results")
    args = parser.parse_args()
    if args.plot:
        plot(args.plot[1:], args.plot[0])
        return
    compile_cache.enable()

    pong = load_experiment()
    device = jax.devices()[0].device_kind
    print(f"device: {device}, jax {jax.__version__}", flush=True)
    fps_rows = []
    for n in args.fps_envs:
        row = {
            "num_envs": n,
            "env": env_fps(pong, n, args.horizon, args.size),
            "a2c": train_fps(pong, n, args.size),
            "a2c_scan": train_fps(pong, n, args.size, per_call=args.scan),
        }
        fps_rows.append(row)
        print(
            f"fps envs={n}: env {row['env']['fps']:,.0f}/s, A2C training {row['a2c']['fps']:,.0f}/s "
            f"(scan of {args.scan}: {row['a2c_scan']['fps']:,.0f}/s)",
            flush=True,
        )
    beat_rows = [
        time_to_beat(pong, n, args.seconds, args.size, args.thresholds, seed, args.call_steps, lr=lr, horizon=t_max)
        for n in args.train_envs
        for t_max in args.t_max
        for lr in args.lr
        for seed in args.seeds
    ]

    print(f"\nPong {args.size}x{args.size}, {device}")
    print(
        f"| envs | env frames/s (random actions) | A2C training frames/s, 1 iteration per call "
        f"| scan of {args.scan} per call | compile env / A2C s |"
    )
    print("|---|---|---|---|---|")
    for r in fps_rows:
        print(
            f"| {r['num_envs']} | {r['env']['fps'] / 1e6:.2f} M | {r['a2c']['fps'] / 1e6:.2f} M "
            f"| {r['a2c_scan']['fps'] / 1e6:.2f} M | {r['env']['compile_s']:.1f} / {r['a2c']['compile_s']:.1f} |"
        )
    print()
    heads = " | ".join(f"running reward > {t:g}" for t in args.thresholds)
    print(f"| A2C envs | t_max | lr | seed | {heads} | final running reward | games | env steps | compile s |")
    print("|---|---|---|---|" + "---|" * (len(args.thresholds) + 4))
    for r in beat_rows:
        cells = [
            f"{v['seconds']:.0f} s ({v['env_steps'] / 1e6:.1f} M steps)" if v else f"not in {r['wall_s']:.0f} s"
            for v in r["reached"].values()
        ]
        print(
            f"| {r['num_envs']} | {r['horizon']} | {r['lr']:g} | {r['seed']} | {' | '.join(cells)} "
            f"| {r['final_running_reward']:.2f} | {r['games']} "
            f"| {r['env_steps'] / 1e6:.1f} M | {r['compile_s']:.1f} |"
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"device": device, "size": args.size, "fps": fps_rows, "beat": beat_rows}, f, indent=1)


if __name__ == "__main__":
    main()
