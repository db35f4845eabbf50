"""Pong from pixels (MinPy's experiment): REINFORCE and A2C on jaxpg's pure-JAX Pong.

The task is ``jaxpg.envs.pong.Pong``, a Pong written for jaxpg (not the Atari ROM), seen through
``FrameDifference``: the observation is the current 80x80 frame minus the previous one, flattened
to 6400. The network is the seed's: 6400 -> 200 (ReLU) -> action probabilities (a categorical
policy over {up, down}); A2C adds a value network of the same shape.

* ``--algo reinforce``: Karpathy's / MinPy's policy gradient. Each env runs on (continuing
  sampling) and every ``--horizon`` steps the policy takes one Adam step on
  ``-E[G^_t log pi(a_t|s_t)]``, where ``G_t`` is the discounted return *of the point* the step
  belongs to (a nonzero reward ends a point, so returns restart there:
  ``jaxpg.algos.reinforce_points``) and ``G^`` is ``G`` normalised over the batch. The steps
  after the last finished point of each env column have no known return yet and are left out.
* ``--algo a2c``: synchronous advantage actor-critic (``jaxpg.algos.a2c``): ``--num-envs`` games
  in lock-step, an update every ``--horizon`` (t_max) steps, GAE(0.99, 0.95) bootstrapped
  through the value of the last frame, value loss and entropy bonus.

The running reward is the seed's: an exponential moving average of the per-game reward (the
final score difference), ``running = 0.99 running + 0.01 game`` at every finished game, starting
from the first game's. ``--compare-envs 1 2 4 16 64 256`` trains the A2C agent with each number
of environments for ``--minutes`` of wall-clock time (compilation excluded) and plots the running
reward against wall-clock time into ``pong_envs.png`` in the run directory: MinPy's comparison,
more environments learn faster in wall-clock time (on one H200 it held from 1 to 1024 envs:
BENCHMARKS.md, section J). The run directory (``--run-dir``, which must not exist) gets
``config.json``, ``metrics.jsonl`` (one line per block of about 0.5 s of training), the plot, and
a GIF of each trained agent playing (``--video-steps``). ``--iterations N`` replaces the
wall-clock budget by exactly ``N`` iterations per run, the same on every machine (tests use it).
Bad arguments exit with status 2 and one ``error:`` line, before anything is written.

    python experiments/pong.py --algo a2c --num-envs 16 --minutes 10
    python experiments/pong.py --algo a2c --num-envs 1024 --lr 2e-3 --minutes 3        # one GPU
    python experiments/pong.py --algo reinforce --num-envs 16 --minutes 30
    python experiments/pong.py --compare-envs 1 2 4 16 64 256 --minutes 5
    python experiments/pong.py --compare-envs 1 4 16 --minutes 1 --size 40      # a quick look on a CPU
    python experiments/pong.py --task atari_pong --compare-envs 1 2 4 16 64 --minutes 20   # the ROM

``--task atari_pong`` plays the Atari ROM in the Arcade Learning Environment instead
(``jaxpg.envs.atari``; the games step on the host's CPU cores): MinPy's comparison on the real game.
For a run that ``python -m jaxpg.evaluate RUN --ale`` can load, train with ``experiments/atari_pong.py``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxpg import train as train_lib
from jaxpg.algos import a2c, reinforce, reinforce_points
from jaxpg.algos.core import TrainState
from jaxpg.cli import Parser, UsageError
from jaxpg.envs import Env, EpisodeStats
from jaxpg.envs.pong import DifferencePong

# The seed's network: one hidden layer of 200 ReLU units.
SEED_NETWORK: dict[str, Any] = dict(policy_hidden=(200,), policy_activation="relu")

# A2C on Pong: the library's recipe (``a2c.PRESETS["pong"]``, shared with experiments/atari_pong.py).
A2C_DEFAULTS: dict[str, Any] = a2c.PRESETS["pong"]

# REINFORCE on Pong: continuing sampling, one Adam step per 256 steps of every env, gamma 0.99.
REINFORCE_DEFAULTS: dict[str, Any] = dict(
    **SEED_NETWORK,
    sampling="continuing",
    horizon=256,
    optimizer="adam",
    lr=1e-3,
    gamma=0.99,
    eval_envs=0,
)

RUNNING_DECAY = 0.99  # running reward: EMA over games, as in the seed


def make_env(size: int = 80, stay_action: bool = False, **pong_kwargs: Any) -> Env:
    """``EpisodeStats(FrameDifference(Pong))`` (the registered task ``pong``): frame differences
    ``[size * size]``, game statistics."""
    return EpisodeStats(DifferencePong(size=size, stay_action=stay_action, **pong_kwargs))


def make_atari_env(stay_action: bool = False) -> Env:
    """``EpisodeStats(AtariPong)``: the ALE ROM's 80x80 frame differences, game statistics."""
    from jaxpg.envs.atari import AtariPong

    return EpisodeStats(AtariPong(action_set="stay" if stay_action else "updown"))


# REINFORCE with returns that restart at every point: ``jaxpg.algos.reinforce_points``.
point_returns = reinforce_points.point_returns
reinforce_update = reinforce_points.update


def make_config(algo: str, num_envs: int, **overrides: Any) -> Any:
    """The ``Config`` of ``algo`` (``"a2c"`` or ``"reinforce"``) for Pong with ``num_envs`` games."""
    if algo == "a2c":
        return a2c.Config(**{**A2C_DEFAULTS, "num_envs": num_envs, **overrides})
    if algo == "reinforce":
        return reinforce.Config(**{**REINFORCE_DEFAULTS, "num_envs": num_envs, **overrides})
    raise ValueError(f"unknown algorithm {algo!r}: expected 'a2c' or 'reinforce'")


ALGORITHMS: dict[str, tuple[Callable, Callable]] = {
    "a2c": (a2c.init, a2c.update),
    "reinforce": (reinforce.init, reinforce_update),
}


# ---------------------------------------------------------------------------------------------
# Host side: the running reward, a wall-clock budget, the plot.


class RunningReward:
    """``jaxpg.train.train`` callback: the seed's running reward and a learning curve.

    After each block it folds the games that ended into ``running`` (the EMA over games; an
    iteration in which ``k`` games ended with mean reward ``m`` counts as ``k`` games of reward
    ``m``) and appends to ``rows`` the wall-clock seconds since ``start``, env steps, iteration,
    running reward, mean reward per step of the block and games ended in it.
    """

    def __init__(self, samples_per_iteration: int, start: float | None = None):
        self.samples_per_iteration = samples_per_iteration
        self.start = time.perf_counter() if start is None else start
        self.running: float | None = None
        self.games = 0
        self.rows: list[dict[str, float]] = []

    def __call__(self, ts: TrainState, metrics: dict[str, np.ndarray], first: int) -> None:
        games, game_reward = metrics["episodes"], metrics["return_stochastic"]
        for k, m in zip(games, game_reward, strict=True):
            if k > 0 and math.isfinite(m):
                if self.running is None:
                    self.running = float(m)
                else:
                    w = RUNNING_DECAY ** float(k)
                    self.running = w * self.running + (1.0 - w) * float(m)
                self.games += int(k)
        iteration = first + len(games)
        self.rows.append(
            {
                "wall_s": time.perf_counter() - self.start,
                "env_steps": iteration * self.samples_per_iteration,
                "iteration": iteration,
                "running_reward": math.nan if self.running is None else self.running,
                "mean_reward": float(np.mean(metrics["mean_reward"])),
                "games": self.games,
            }
        )


def _jitted_copy(tree: Any) -> Any:
    return jax.jit(lambda t: jax.tree.map(jnp.copy, t))(tree)


def train_for(
    algo: str,
    env: Env,
    config: Any,
    seconds: float,
    seed: int = 0,
    call_steps: int = 2048,
    block_seconds: float = 0.5,
    log: Callable[[str], None] = print,
    log_every_s: float = 15.0,
    iterations: int | None = None,
) -> tuple[TrainState, RunningReward, float]:
    """Train ``algo`` for ``seconds`` of wall-clock time, compilation excluded, or, when
    ``iterations`` is given, for exactly that many iterations (``seconds`` is then ignored).

    Each compiled call runs ``per_call = clip(round(call_steps / samples_per_iteration), 1, 256)``
    iterations in a ``lax.scan`` (one iteration per call at GPU-sized batches, many at small
    ones, where a call's latency would otherwise dominate). Calls are dispatched without waiting,
    and the host fetches metrics once per block of calls; the number of calls per block adapts so
    that a block takes about ``block_seconds``, because waiting for the device after every
    iteration costs a third of the throughput at 2048 envs on an H200. The program is compiled
    (and run once on a throwaway copy of the state) before the clock starts. Returns the final
    state, the ``RunningReward`` record and the compilation seconds.
    """
    init, update = ALGORITHMS[algo]
    per_call = int(np.clip(round(call_steps / config.samples_per_iteration), 1, 256))
    t0 = time.perf_counter()
    ts = init(jax.random.PRNGKey(seed), env, config)
    jax.block_until_ready(train_lib.compiled_block(update, per_call, False)(_jitted_copy(ts)))
    compile_s = time.perf_counter() - t0
    record = RunningReward(config.samples_per_iteration)
    last_log = record.start
    calls, done = 1, 0

    def more() -> bool:
        return done < iterations if iterations is not None else time.perf_counter() - record.start < seconds

    while more():
        started = time.perf_counter()
        n = calls * per_call if iterations is None else min(calls * per_call, iterations - done)
        ts = train_lib.train(update, ts, n, block_size=n, callbacks=[record], iterations_per_call=per_call)
        done += n
        took = time.perf_counter() - started
        calls = int(np.clip(calls * block_seconds / max(took, 1e-6), 1, 2 * calls))
        now = time.perf_counter()
        if now - last_log >= log_every_s:
            last_log = now
            row = record.rows[-1]
            log(
                f"  {algo} envs {config.num_envs:4d}  {row['wall_s']:7.1f} s  {row['env_steps'] / 1e6:7.2f} M steps "
                f"({row['env_steps'] / row['wall_s']:8.0f}/s)  games {row['games']:6d}  "
                f"running reward {row['running_reward']:7.2f}  reward/step {row['mean_reward']:+.4f}"
            )
    return ts, record, compile_s


def plot_curves(curves: dict[str, Sequence[dict[str, float]]], path: Path, title: str) -> None:
    """Running reward (top) and mean reward per step (bottom) against wall-clock seconds."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    colors = plt.get_cmap("viridis")(np.linspace(0.0, 0.9, max(len(curves), 1)))
    for (label, rows), color in zip(curves.items(), colors, strict=True):
        t = np.array([r["wall_s"] for r in rows])
        top.plot(t, [r["running_reward"] for r in rows], color=color, label=label)
        bottom.plot(t, [r["mean_reward"] for r in rows], color=color, label=label, alpha=0.8)
    top.set_ylabel("running reward (EMA of game score)")
    bottom.set_ylabel("mean reward per step")
    bottom.set_xlabel("wall-clock seconds (compilation excluded)")
    top.set_title(title)
    top.legend()
    top.grid(alpha=0.3)
    bottom.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="python experiments/pong.py",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="\n\n".join(__doc__.split("\n\n")[1:]),
    )
    parser.add_argument(
        "--task",
        choices=("pong", "atari_pong"),
        default="pong",
        help="pong: jaxpg's own Pong; atari_pong: the Atari ROM in ALE (pip install 'jaxpg[atari]'; no GIF)",
    )
    parser.add_argument("--algo", choices=sorted(ALGORITHMS), default="a2c")
    parser.add_argument("--num-envs", type=int, nargs="+", default=[16], help="one run per value, in turn")
    parser.add_argument(
        "--compare-envs", type=int, nargs="+", help="A2C with each number of envs; plot into pong_envs.png"
    )
    parser.add_argument("--minutes", type=float, default=5.0, help="wall-clock budget of each run")
    parser.add_argument(
        "--iterations",
        type=int,
        help="instead of --minutes: exactly this many iterations per run (machine-independent)",
    )
    parser.add_argument("--size", type=int, default=80, help="frames are size x size pixels (>= 8)")
    parser.add_argument("--stay-action", action="store_true", help="actions {stay, up, down}")
    parser.add_argument("--horizon", type=int, help="steps per env per update (A2C's t_max)")
    parser.add_argument("--lr", type=float, help="learning rate")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--call-steps", type=int, default=2048, help="about this many env steps per compiled call (a lax.scan)"
    )
    parser.add_argument(
        "--video-steps",
        type=int,
        default=1000,
        help="after each run, a GIF of the trained agent playing this many steps (0: none)",
    )
    parser.add_argument("--run-dir", type=Path, help="default: runs/pong-<algo>-<time>; must not exist")
    return parser


def check_args(args: argparse.Namespace) -> None:
    """Raise ``UsageError`` (one line) for arguments that cannot run, before anything is written."""
    counts = args.compare_envs if args.compare_envs is not None else args.num_envs
    if any(n < 1 for n in counts):
        raise UsageError(f"numbers of envs must be >= 1, got {' '.join(map(str, counts))}")
    if not args.minutes > 0:
        raise UsageError(f"--minutes must be > 0, got {args.minutes:g}")
    if args.iterations is not None and args.iterations < 1:
        raise UsageError(f"--iterations must be >= 1, got {args.iterations}")
    if args.size < 8:
        raise UsageError(f"--size must be >= 8, got {args.size}")
    if args.horizon is not None and args.horizon < 1:
        raise UsageError(f"--horizon must be >= 1, got {args.horizon}")
    if args.lr is not None and not args.lr > 0:
        raise UsageError(f"--lr must be > 0, got {args.lr:g}")
    if args.call_steps < 1 or args.video_steps < 0:
        raise UsageError("--call-steps must be >= 1 and --video-steps >= 0")
    if args.run_dir.exists():
        raise UsageError(f"run directory {args.run_dir} exists; choose another --run-dir (nothing was changed)")


def record_game(env: Env, ts: TrainState, key: jax.Array, steps: int) -> np.ndarray:
    """``[steps, size, size]`` uint8 frames of the trained policy (sampling) playing from a fresh
    game; a game that ends starts again (``AutoReset``)."""
    from jaxpg.envs import AutoReset

    game = AutoReset(env)
    size = int(math.isqrt(env.observation_size))

    @jax.jit
    def play(key: jax.Array) -> jax.Array:
        reset_key, act_key = jax.random.split(key)

        def step(state: Any, k: jax.Array) -> tuple[Any, jax.Array]:
            action = ts.policy.sample(ts.params, ts.obs_stats.normalize(state.obs[None]), k)[0][0]
            state = game.step(state, action)
            return state, state.info["prev_frame"]

        _, frames = jax.lax.scan(step, game.reset(reset_key), jax.random.split(act_key, steps))
        return frames

    frames = np.asarray(play(key)).reshape(steps, size, size)
    return (np.clip(frames, 0.0, 1.0) * 255).astype(np.uint8)


def save_game_gif(frames: np.ndarray, path: Path, scale: int = 3, fps: float = 50.0) -> Path:
    """Write ``[T, size, size]`` uint8 frames, each pixel ``scale x scale``, as a looping GIF."""
    from jaxpg import video

    big = frames.repeat(scale, axis=1).repeat(scale, axis=2)
    return video.write_video([np.stack([f, f, f], axis=-1) for f in big], path, fps)


def plan(argv: Sequence[str] | None) -> argparse.Namespace:
    """Parsed and checked arguments, with the run directory filled in and ``algo`` set to
    ``"a2c"`` in comparison mode; ``UsageError`` if bad."""
    args = build_parser().parse_args(argv)
    if args.compare_envs is not None:
        args.algo = "a2c"  # the comparison is A2C's
    args.run_dir = args.run_dir or Path("runs") / f"{args.task}-{args.algo}-{time.strftime('%Y%m%d-%H%M%S')}"
    if args.task == "atari_pong":
        if args.size != 80:
            raise UsageError("--size is jaxpg Pong's; atari_pong's frames are 80x80")
        args.video_steps = 0  # the GIF draws jaxpg Pong's frames
    check_args(args)
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status (2 with one ``error:`` line for bad input)."""
    try:
        args = plan(argv)
    except UsageError as e:
        print(f"error: {str(e).strip().splitlines()[0]}", file=sys.stderr)
        return 2
    from jaxpg import compile_cache

    compile_cache.enable()
    compare = args.compare_envs is not None
    algo = args.algo
    counts = args.compare_envs if compare else args.num_envs
    overrides = {k: v for k, v in (("horizon", args.horizon), ("lr", args.lr)) if v is not None}
    env = make_env(args.size, args.stay_action) if args.task == "pong" else make_atari_env(args.stay_action)
    configs = {n: make_config(algo, n, **overrides) for n in counts}
    run_dir = args.run_dir
    run_dir.mkdir(parents=True)
    device = jax.devices()[0]
    info = {
        "argv": list(sys.argv if argv is None else argv),
        "algo": algo,
        "device": f"{device} ({device.device_kind})",
        "jax": jax.__version__,
        "env": repr(env),
        "configs": {n: dataclasses.asdict(c) for n, c in configs.items()},
    }
    (run_dir / "config.json").write_text(json.dumps(info, indent=2, default=str))
    budget = f"{args.minutes:g} min" if args.iterations is None else f"{args.iterations} iterations"
    print(f"run directory {run_dir}; {algo} on {env!r}, {budget} per run on {device.device_kind}")

    curves: dict[str, list[dict[str, float]]] = {}
    with open(run_dir / "metrics.jsonl", "w") as out:
        for n, config in configs.items():
            print(f"{algo} with {n} envs (horizon {config.horizon}, {config.samples_per_iteration} samples/iteration)")
            ts, record, compile_s = train_for(
                algo,
                env,
                config,
                60.0 * args.minutes,
                seed=args.seed,
                call_steps=args.call_steps,
                iterations=args.iterations,
            )
            for row in record.rows:
                row = {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in row.items()}
                out.write(json.dumps({"algo": algo, "num_envs": n, **row}) + "\n")
            out.flush()
            last = record.rows[-1]
            print(
                f"{algo} envs {n}: compiled in {compile_s:.1f} s; {last['env_steps'] / 1e6:.2f} M steps, "
                f"{last['games']} games in {last['wall_s']:.0f} s; running reward {last['running_reward']:.2f}"
            )
            curves[f"{n} env{'s' if n > 1 else ''}"] = record.rows
            if args.video_steps:
                frames = record_game(env, ts, jax.random.PRNGKey(args.seed + 1), args.video_steps)
                print(f"wrote {save_game_gif(frames, run_dir / f'pong_{algo}_{n}envs.gif')}")

    name = "pong_envs.png" if compare else f"pong_{algo}.png"
    lr = configs[counts[0]].lr
    game = "jaxpg Pong" if args.task == "pong" else "Atari Pong (ALE)"
    title = f"{algo.upper()} on {game} ({args.size}x{args.size} frame differences, lr {lr:g}), {device.device_kind}"
    plot_curves(curves, run_dir / name, title)
    print(f"wrote {run_dir / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
