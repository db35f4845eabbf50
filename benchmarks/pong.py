"""Pong from pixels: frames per second, MinPy's comparison of env counts, and time for A2C to beat the opponent.

Measurements on jaxpg's pure-JAX Pong (the task ``pong``: frame differences of 80x80 frames; not
the Atari ROM):

  fps      frames (env steps) per second of ``--fps-envs`` games with random actions, in a jitted
           ``lax.scan`` of ``--horizon`` steps, timed after compilation; and of A2C training
           (sampling with the seed's 6400 -> 200 -> 2 network plus the update) at the same batch;
  beat     A2C runs of ``experiments/pong.py`` with ``--train-envs`` games and each of ``--seeds``,
           ``--lr`` (default 2e-3: at 1024 envs on an H200 it did better than 4e-3, and at 2048
           envs better than 1e-3) and ``--t-max``, each trained for ``--seconds`` of wall clock
           (compilation excluded) or exactly ``--iterations``: when the seed's running reward
           first exceeds each of ``--thresholds`` (0: the agent beats the scripted opponent on
           average; 10: by 10 points of 21);
  compare  MinPy's comparison, ``--compare-envs 1 2 4 16 ...``: the same A2C runs with each number
           of envs (the experiment's learning rate unless ``--lr`` is given, no fps measurement),
           and their running reward against wall clock in ``RUN_DIR/pong_envs.png``: more envs
           learn faster in wall-clock time (on one H200 it held from 1 to 1024 envs:
           docs/benchmarks_archive.md, section J). ``--algo ppo`` runs the same comparison with PPO (the
           experiment's settings, e.g. PPO's Atari recipe on the ROM, which learns there in
           minutes where MinPy's A2C needs tens of minutes per setting).

Every A2C run is a standard run of the command line (``jaxpg.run.command.planning.plan`` of ``experiments/pong.py``
with ``--minutes``, run by ``jaxpg.run.training.session.execute``) in ``RUN_DIR/envs<N>-tmax<T>-lr<LR>-seed<S>``,
so ``python -m jaxpg.evaluate``, ``jaxpg.load_policy`` and ``--resume`` work on each. The running
reward is the seed's, computed from its ``metrics.jsonl``: an exponential moving average of the
final score difference of the games, ``running = 0.99 running + 0.01 game`` at every finished
game, starting from the first game's. Its clock starts when the run's first compiled block (which
compiles) has finished. ``--iterations N`` replaces the wall-clock budget by exactly ``N``
iterations per run, the same on every machine (tests use it). ``--task atari_pong`` runs the
comparison on the Atari ROM (``experiments/atari_pong.py``; needs ``pip install 'jaxpg[atari]'``).

    python benchmarks/pong.py --fps-envs 1024 4096 --train-envs 1024 --seeds 0 1 2 --seconds 150 --json pong.json
    python benchmarks/pong.py --fps-envs 8 --train-envs 8 --seconds 5 --size 40     # CPU smoke run
    python benchmarks/pong.py --compare-envs 1 2 4 16 64 256 --seconds 300 --run-dir runs/pong-envs
    python benchmarks/pong.py --compare-envs 1 4 16 --seconds 30 --size 40 --run-dir runs/pong-cpu   # a CPU
    python benchmarks/pong.py --task atari_pong --compare-envs 1 2 4 16 64 --seconds 1200 --run-dir runs/atari-envs
    python benchmarks/pong.py --task atari_pong --algo ppo --compare-envs 1 4 16 64 --seconds 150 --run-dir runs/ppo
    python benchmarks/pong.py --plot docs/pong_a2c_h200.png benchmarks/results/2026-11-22-h200/pong*.json
    python benchmarks/pong.py --fps-envs --train-envs 2048 --lr 1e-3 2e-3 4e-3 --seconds 125   # the lr sweep

``python benchmarks/pong.py atari-fps`` measures the frames per second of the Atari ROM's paths
instead (``atari-fps --help``).
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import harness
import jax
import jax.numpy as jnp
import numpy as np

from jaxpg import algos, envs
from jaxpg.envs import atari
from jaxpg.run.command import command_line, flags, planning
from jaxpg.run.command import plan as plan_lib
from jaxpg.run.host import compile_cache
from jaxpg.run.outputs import metrics_log
from jaxpg.run.rundir import config_io, layout
from jaxpg.run.training import session

ROOT = Path(__file__).resolve().parents[1]
RUNNING_DECAY = 0.99  # running reward: EMA over games, as in the seed
EXPERIMENTS = {"pong": "experiments/pong.py", "atari_pong": "experiments/atari_pong.py"}
NO_LIMIT = 10**9  # iterations of a run that stops at its time limit


def load_experiment(task: str) -> command_line.Experiment:
    """The ``EXPERIMENT`` of the experiment script that trains ``task``."""
    path = ROOT / EXPERIMENTS[task]
    spec = importlib.util.spec_from_file_location(f"{task}_experiment", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.EXPERIMENT


def a2c_config(num_envs: int) -> Any:
    """``a2c.Config`` of A2C on Pong (``a2c.PRESETS["pong"]``) with ``num_envs`` games."""
    return algos.get("a2c").Config(**algos.preset("a2c", "pong", "pong"), num_envs=num_envs)


# ---------------------------------------------------------------------------------------------
# fps: the env and one training iteration, timed after compilation.


def env_fps(num_envs: int, horizon: int, size: int, repeats: int = 3) -> dict:
    """Frames/s of ``num_envs`` games stepped with random actions (auto-reset included)."""
    from jaxpg import rollout as rollout_lib

    env = envs.AutoReset(envs.make_shared("pong", size=size))
    state = rollout_lib.reset_batch(env, jax.random.PRNGKey(0), num_envs)

    def random_act(params, obs, key):  # noqa: ANN001, ANN202
        del params
        return jax.random.randint(key, obs.shape[:1], 0, env.action_size), jnp.zeros(obs.shape[0])

    run = jax.jit(lambda s, k: rollout_lib.rollout(env, random_act, None, s, k, horizon)[0])
    chain = [state]

    def call(i: int) -> Any:  # each call continues from the last one's games
        chain.append(run(chain[-1], jax.random.PRNGKey(1 + i)))
        return chain[-1]

    compile_s, seconds, _ = harness.time_calls(call, repeats)
    return {"fps": num_envs * horizon / seconds, "compile_s": compile_s}


def train_fps(num_envs: int, size: int, per_call: int = 1, iterations: int = 24) -> dict:
    """Frames/s of A2C training iterations (sampling + update), ``per_call`` iterations per compiled
    call (a ``lax.scan``), calls dispatched without waiting."""
    from jaxpg import train as train_lib

    a2c = algos.get("a2c")
    config = a2c_config(num_envs)
    ts = train_lib.own_buffers(a2c.init(jax.random.PRNGKey(0), envs.make_shared("pong", size=size), config))
    step = train_lib.compiled_block(a2c.update, per_call, False)
    compile_s, seconds, _ = harness.time_back_to_back(step, ts, max(1, iterations // per_call))
    return {
        "fps": config.samples_per_iteration * per_call / seconds,
        "compile_s": compile_s,
        "iterations_per_call": per_call,
    }


# ---------------------------------------------------------------------------------------------
# A2C runs through the command line, and the running reward from their metrics.


def run_name(num_envs: int, horizon: int | None, lr: float | None, seed: int, algo: str = "a2c") -> str:
    """The run directory's name under ``--run-dir``: ``envs16-seed0``, with ``-tmax5`` and ``-lr0.002``
    where they are not the experiment's, and the algorithm in front when it is not A2C
    (``ppo-envs16-seed0``)."""
    tmax = "" if horizon is None else f"-tmax{horizon}"
    prefix = "" if algo == "a2c" else f"{algo}-"
    return f"{prefix}envs{num_envs}{tmax}{'' if lr is None else f'-lr{lr:g}'}-seed{seed}"


def experiment_horizon(task: str, algo: str) -> int:
    """Env steps per iteration and env of ``algo`` in the experiment that trains ``task``."""
    config = load_experiment(task).config.get(algo, {})
    return config.get("horizon", algos.get(algo).Config().horizon)


def run_argv(
    run_dir: Path,
    task: str,
    num_envs: int,
    seed: int = 0,
    lr: float | None = None,
    horizon: int | None = None,
    seconds: float | None = None,
    iterations: int | None = None,
    size: int | None = None,
    call_steps: int = 2048,
    algo: str = "a2c",
) -> list[str]:
    """The experiment's command line of one ``algo`` run (A2C: MinPy's comparison; PPO, the
    experiment's default on the ROM): ``iterations``, or ``seconds`` of training.

    A compiled call (a block, between metrics reaching the host) covers about ``call_steps`` env
    steps (1 to 256 iterations): one iteration at GPU-sized batches, many at small ones, where a
    call's latency would otherwise dominate. Checkpoints only at the end.
    """
    samples = num_envs * (horizon or experiment_horizon(task, algo))
    per_call = min(max(round(call_steps / samples), 1), 256)
    argv = ["--algo", algo, "--num-envs", str(num_envs), "--seed", str(seed), "--run-dir", str(run_dir)]
    argv += ["--log-every", str(per_call), "--checkpoint-every", "0", "--no-progress"]
    argv += ["--iterations", str(iterations or NO_LIMIT)]
    if iterations is None:
        argv += ["--minutes", repr(seconds / 60.0)]
    for flag, value in (("--lr", lr), ("--horizon", horizon), ("--size", size)):
        if value is not None:
            argv += [flag, repr(value) if isinstance(value, float) else str(value)]
    return argv


def train_run(plan: plan_lib.Plan) -> None:
    """Run one planned command line (``jaxpg.run.training.session.execute``); ``RuntimeError`` if it does not
    finish with status 0."""
    status = session.execute(plan)
    if status != 0:
        raise RuntimeError(f"the run {' '.join(plan.command)} ended with status {status}")


def running_reward(records: Sequence[dict[str, Any]], block: int, decay: float = RUNNING_DECAY) -> list[dict]:
    """The seed's running reward along a run's ``metrics.jsonl`` records (one seed).

    An iteration in which ``k`` games ended with mean final score ``m`` counts as ``k`` games of
    score ``m``: ``running = decay^k running + (1 - decay^k) m`` (the first game's score first).
    ``wall_s`` counts from the end of iteration ``block`` (the first compiled block, which
    compiles); the records of that block are left out. Each row: ``wall_s``, ``env_steps``,
    ``iteration``, ``running_reward`` (NaN before the first game ended), ``mean_reward`` (per
    step), ``games`` (so far).
    """
    block = min(block, records[-1]["iteration"])
    start = next(r["wall_time_s"] for r in records if r["iteration"] == block)
    running, games, rows = math.nan, 0, []
    for r in records:
        k, score = int(r.get("episodes") or 0), r.get("return_stochastic")
        if k > 0 and score is not None:
            running = score if math.isnan(running) else decay**k * running + (1.0 - decay**k) * score
            games += k
        if r["iteration"] > block:
            rows.append(
                {
                    "wall_s": r["wall_time_s"] - start,
                    "env_steps": r["env_steps"],
                    "iteration": r["iteration"],
                    "running_reward": running,
                    "mean_reward": r["mean_reward"],
                    "games": games,
                }
            )
    return rows


def summarize(run_dir: Path, thresholds: Sequence[float]) -> dict:
    """One run's results: its settings, seconds of its first block (compilation included),
    wall-clock seconds
    and env steps at which the running reward first exceeded each threshold (``None`` where it never
    did), the final running reward, and the curve at most twice a second."""
    run = config_io.RunConfig.load(run_dir)
    records = metrics_log.read_metrics(run_dir / layout.METRICS_FILE)
    curve = running_reward(records, run.block_size)
    block = min(run.block_size, records[-1]["iteration"])
    first_block = next(r["wall_time_s"] for r in records if r["iteration"] == block)
    reached = {}
    for threshold in thresholds:
        first = next((r for r in curve if r["running_reward"] > threshold), None)
        reached[str(threshold)] = (
            None if first is None else {"seconds": first["wall_s"], "env_steps": first["env_steps"]}
        )
    kept, last_kept = [], -math.inf
    for r in curve:
        if r["wall_s"] - last_kept >= 0.5 or r is curve[-1]:
            kept.append({k: None if isinstance(v, float) and math.isnan(v) else v for k, v in r.items()})
            last_kept = r["wall_s"]
    last = curve[-1] if curve else {"running_reward": math.nan, "games": 0, "env_steps": 0, "wall_s": 0.0}
    return {
        "run_dir": str(run_dir),
        "algo": run.algo,
        "num_envs": run.config["num_envs"],
        "seed": run.seeds[0],
        "lr": run.config["lr"],
        "horizon": run.config["horizon"],
        "first_block_s": first_block,
        "reached": reached,
        "final_running_reward": last["running_reward"],
        "games": last["games"],
        "env_steps": last["env_steps"],
        "wall_s": last["wall_s"],
        "curve": kept,
    }


def plot(runs: Sequence[dict], out: str | Path, title: str) -> None:
    """Running reward against wall clock, one line per run (a colour per setting), into ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    settings = sorted({(r["num_envs"], r.get("horizon", 8), r.get("lr", 1e-3), r.get("algo", "a2c")) for r in runs})
    cmap = plt.get_cmap("viridis") if len(settings) > 10 else None
    colors = (
        dict(zip(settings, cmap([i / max(len(settings) - 1, 1) for i in range(len(settings))]), strict=True))
        if cmap
        else dict(zip(settings, plt.get_cmap("tab10").colors, strict=False))
    )
    fig, ax = plt.subplots(figsize=(8, 4.5))
    labelled = set()
    for run in runs:
        key = (run["num_envs"], run.get("horizon", 8), run.get("lr", 1e-3), run.get("algo", "a2c"))
        envs = f"{key[0]} env{'s' if key[0] > 1 else ''}"
        label = None if key in labelled else f"{key[3].upper()}, {envs}, horizon {key[1]}, lr {key[2]:g}"
        labelled.add(key)
        t = [row["wall_s"] for row in run["curve"]]
        reward = [math.nan if row["running_reward"] is None else row["running_reward"] for row in run["curve"]]
        ax.plot(t, reward, color=colors.get(key), lw=1.2, label=label)
    ax.axhline(0.0, color="k", lw=0.8, ls="--")
    ax.axhline(10.0, color="k", lw=0.8, ls=":")
    ax.set_xlabel("wall-clock seconds (compilation excluded)")
    ax.set_ylabel("running reward (EMA of game score)")
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)


def plot_files(json_paths: Sequence[str], out: str) -> None:
    """``plot`` of every run in earlier ``--json`` files (e.g. one file per number of envs)."""
    runs, device, task = [], "", "pong"
    for path in json_paths:
        with open(path) as f:
            result = json.load(f)
        runs += result["beat"]
        device, task = result["device"], result.get("task", "pong")
    game = "jaxpg Pong from frame differences" if task == "pong" else "Atari Pong (ALE)"
    plot(runs, out, f"{game}, {device}: one line per run (seed)")


# ---------------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    parser = command_line.Parser(
        prog="python benchmarks/pong.py",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="\n\n".join(__doc__.split("\n\n")[1:]),
    )
    parser.add_argument("--task", choices=sorted(EXPERIMENTS), default="pong", help="atari_pong: the ROM, in ALE")
    parser.add_argument("--fps-envs", type=int, nargs="*", help="default: 1024 4096; none with --compare-envs")
    parser.add_argument("--horizon", type=int, default=128, help="env steps per timed call (fps)")
    parser.add_argument("--train-envs", type=int, nargs="*", default=[1024], help="A2C runs with each number of envs")
    parser.add_argument(
        "--compare-envs", type=int, nargs="+", help="MinPy's comparison: A2C runs with each, plot into pong_envs.png"
    )
    parser.add_argument(
        "--algo",
        choices=("a2c", "ppo"),
        default="a2c",
        help="the runs' algorithm (a2c: MinPy's; ppo: the ROM's default)",
    )
    parser.add_argument("--seconds", type=float, default=240.0, help="wall-clock budget of each A2C run")
    parser.add_argument("--iterations", type=int, help="instead of --seconds: exactly this many iterations per run")
    parser.add_argument(
        "--lr", type=float, nargs="+", help="A2C runs for each learning rate (default: 2e-3; the experiment's 1e-3 "
        "with --compare-envs)"
    )  # fmt: skip
    parser.add_argument("--seeds", type=int, nargs="+", default=[0], help="A2C runs for each seed")
    parser.add_argument("--call-steps", type=int, default=2048, help="env steps per compiled call while training")
    parser.add_argument("--t-max", type=int, nargs="+", help="A2C runs for each t_max (default: the experiment's, 8)")
    parser.add_argument("--scan", type=int, default=8, help="also time A2C with this many iterations per call")
    parser.add_argument("--thresholds", type=float, nargs="+", default=[0.0, 10.0])
    parser.add_argument("--size", type=int, help="frames are SIZE x SIZE pixels (pong; default 80)")
    parser.add_argument("--run-dir", type=Path, help="the A2C runs go here (default: runs/pong-benchmark-<time>)")
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--plot", nargs="+", metavar=("OUT", "JSON"), help="only plot earlier --json results")
    return parser


def check(args: argparse.Namespace) -> None:
    """``UsageError`` (one line) for arguments that cannot run, before anything is written."""
    counts = [*(args.fps_envs or []), *(args.compare_envs or args.train_envs)]
    if any(n < 1 for n in counts):
        raise flags.UsageError(f"numbers of envs must be >= 1, got {' '.join(map(str, counts))}")
    if not args.seconds > 0:
        raise flags.UsageError(f"--seconds must be > 0, got {args.seconds:g}")
    if args.iterations is not None and args.iterations < 1:
        raise flags.UsageError(f"--iterations must be >= 1, got {args.iterations}")
    if args.task != "pong" and (args.size is not None or args.fps_envs):
        raise flags.UsageError("--size and --fps-envs are jaxpg Pong's (--task pong)")
    if args.run_dir is not None and args.run_dir.exists():
        raise flags.UsageError(f"{args.run_dir} exists; choose another --run-dir (nothing was changed)")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status (2 with one ``error:`` line for bad input)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["atari-fps"]:
        return atari_fps_main(argv[1:])
    try:
        args = build_parser().parse_args(argv)
        if args.plot:
            plot_files(args.plot[1:], args.plot[0])
            return 0
        compare = args.compare_envs is not None
        args.fps_envs = args.fps_envs if args.fps_envs is not None else ([] if compare else [1024, 4096])
        check(args)
        root = args.run_dir or Path("runs") / f"pong-benchmark-{datetime.datetime.now():%Y%m%d-%H%M%S}"
        experiment = load_experiment(args.task)
        budget = dict(
            seconds=args.seconds, iterations=args.iterations, size=args.size, call_steps=args.call_steps, algo=args.algo
        )
        plans = [
            planning.plan(
                run_argv(root / run_name(n, t_max, lr, seed, args.algo), args.task, n, seed, lr, t_max, **budget),
                experiment,
            )
            for n in args.compare_envs or args.train_envs
            for t_max in args.t_max or [None]
            for lr in args.lr or ([None] if compare or args.algo != "a2c" else [2e-3])
            for seed in args.seeds
        ]
    except ValueError as e:  # UsageError, or a run the command line refuses
        print(f"error: {str(e).strip().splitlines()[0]}", file=sys.stderr)
        return 2
    compile_cache.enable()
    size = args.size or 80
    device = jax.devices()[0].device_kind
    print(f"device: {device}, jax {jax.__version__}", flush=True)
    fps_rows = []
    for n in args.fps_envs:
        row = {
            "num_envs": n,
            "env": env_fps(n, args.horizon, size),
            "a2c": train_fps(n, size),
            "a2c_scan": train_fps(n, size, per_call=args.scan),
        }
        fps_rows.append(row)
        print(
            f"fps envs={n}: env {row['env']['fps']:,.0f}/s, A2C training {row['a2c']['fps']:,.0f}/s "
            f"(scan of {args.scan}: {row['a2c_scan']['fps']:,.0f}/s)",
            flush=True,
        )
    beat_rows = []
    for plan in plans:
        train_run(plan)
        beat_rows.append(summarize(plan.run_dir, args.thresholds))

    game = f"jaxpg Pong ({size}x{size} frame differences)" if args.task == "pong" else "Atari Pong (ALE)"
    if compare:
        plot(beat_rows, root / "pong_envs.png", f"{args.algo.upper()} on {game}, {device}")
        print(f"wrote {root / 'pong_envs.png'}")
    print(f"\n{game}, {device}")
    if fps_rows:
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
    print(f"| algo | envs | horizon | lr | seed | {heads} | final running reward | games | env steps | first block s |")
    print("|---|---|---|---|---|" + "---|" * (len(args.thresholds) + 4))
    for r in beat_rows:
        cells = [
            f"{v['seconds']:.0f} s ({v['env_steps'] / 1e6:.1f} M steps)" if v else f"not in {r['wall_s']:.0f} s"
            for v in r["reached"].values()
        ]
        print(
            f"| {r['algo']} | {r['num_envs']} | {r['horizon']} | {r['lr']:g} | {r['seed']} | {' | '.join(cells)} "
            f"| {r['final_running_reward']:.2f} | {r['games']} "
            f"| {r['env_steps'] / 1e6:.1f} M | {r['first_block_s']:.1f} |"
        )
    if args.json:
        with open(args.json, "w") as f:
            result = {"device": device, "task": args.task, "size": size, "fps": fps_rows, "beat": beat_rows}
            json.dump(result, f, indent=1)
    return 0


# ---------------------------------------------------------------------------------------------
# atari-fps: the Atari ROM's paths, frames per second

ATARI_FPS_DOC = """Frames per second of each way to play Atari Pong on the host's CPU cores and the device.

Rows (``B`` games stepped together, each path timed for ``--seconds`` after a warm-up call,
compilation excluded):

* ``ALE vector env``: ALE's games with ``atari_pong``'s settings (RGB 210x160 frames, four frames
  per step), stepped from Python with random actions.
* ``atari_pong scan``: the task (``jaxpg.envs.atari``) in a jitted ``lax.scan``: ALE through the
  batched ``io_callback``, Karpathy's preprocessing and frame difference, and the 6400 -> 200 -> 2
  policy sampling each action: what the learner's sampling phase costs.
* ``a2c training``: ``experiments/atari_pong.py``'s A2C (horizon 8) end to end, learning included.

``frames/s`` counts emulator frames (four per agent step).

    python benchmarks/pong.py atari-fps                   # B = 1 4 16, about a minute on 2 cores
    python benchmarks/pong.py atari-fps --envs 16 64 256 1024 --seconds 5
"""


def ale_vector(num_envs: int, seconds: float) -> float:
    """Agent steps per second of ALE's vector env with ``atari_pong``'s settings."""
    pool = atari.AlePool(num_envs, sticky=True, frameskip=atari.FRAMESKIP, max_frames=10**7, seed=0)
    rng = np.random.default_rng(0)
    zeros = np.ones(num_envs, np.int64)

    def run() -> None:
        pool.step(rng.integers(2, 4, size=num_envs), zeros)

    elapsed, calls = harness.time_for(run, seconds)
    return calls * num_envs / elapsed


def a2c_state(num_envs: int) -> Any:
    """A fresh A2C ``TrainState`` with ``experiments/atari_pong.py``'s settings on ``atari_pong``."""
    from jaxpg.algos import a2c
    from jaxpg.envs import EpisodeStats

    env = EpisodeStats(atari.AtariPong())
    network = dict(policy_hidden=(200,), policy_activation="relu", value_hidden=(200,), value_activation="relu")
    config = a2c.Config(**network, num_envs=num_envs, horizon=8, lr=1e-3, gae_lambda=0.95, eval_envs=0)
    return jax.jit(lambda k: a2c.init(k, env, config))(jax.random.PRNGKey(0))


def atari_pong_scan(num_envs: int, seconds: float, blocks: int = 8) -> float:
    """Agent steps per second of sampling alone (the task and the policy in a jitted scan)."""
    from jaxpg.algos import core

    box = [a2c_state(num_envs)]

    @jax.jit
    def run(ts: Any) -> Any:
        def body(ts: Any, key: jax.Array) -> tuple[Any, None]:
            env_state, _ = core.sample(ts, key)
            return ts.replace(env_state=env_state), None

        return jax.lax.scan(body, ts, jax.random.split(jax.random.PRNGKey(1), blocks))[0]

    def step() -> Any:
        box[0] = run(box[0])
        return box[0].env_state.obs

    elapsed, calls = harness.time_for(step, seconds)
    return calls * blocks * box[0].config.samples_per_iteration / elapsed


def a2c_training(num_envs: int, seconds: float, iterations: int = 8) -> float:
    """Agent steps per second of A2C training (``experiments/atari_pong.py``'s settings)."""
    from jaxpg import train as train_lib
    from jaxpg.algos import a2c

    box = [a2c_state(num_envs)]
    block = train_lib.compiled_block(a2c.update, iterations, False)

    def run() -> Any:
        box[0], metrics = block(box[0])
        return metrics

    elapsed, calls = harness.time_for(run, seconds)
    return calls * iterations * box[0].config.samples_per_iteration / elapsed


def atari_fps_main(argv: Sequence[str]) -> int:
    parser = argparse.ArgumentParser(
        prog="python benchmarks/pong.py atari-fps",
        description=ATARI_FPS_DOC,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--envs", type=int, nargs="+", default=[1, 4, 16], help="games stepped together")
    parser.add_argument("--seconds", type=float, default=3.0, help="timing of each row")
    args = parser.parse_args(argv)
    atari.require_ale()
    print(f"{harness.describe()}; frames/s = emulator frames per second")
    print(f"{'path':18s} {'B':>5s} {'agent steps/s':>14s} {'frames/s':>12s}")
    paths = (
        ("ALE vector env", ale_vector, atari.FRAMESKIP),
        ("atari_pong scan", atari_pong_scan, atari.FRAMESKIP),
        ("a2c training", a2c_training, atari.FRAMESKIP),
    )
    for name, measure, frames_per_step in paths:
        for num_envs in args.envs:
            steps = measure(num_envs, args.seconds)
            print(f"{name:18s} {num_envs:5d} {steps:14,.0f} {steps * frames_per_step:12,.0f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
