"""Pong from pixels: frames per second, MinPy's comparison of env counts, and time for A2C to beat the opponent.

Measurements on jaxpg's pure-JAX Pong (the task ``pong``: frame differences of 80x80 frames; not
the Atari ROM):

  fps      frames (env steps) per second of ``--fps-envs`` games with random actions, in a jitted
           ``lax.scan`` of ``--horizon`` steps, timed after compilation; and of A2C training
           (sampling with the seed's 6400 -> 200 -> 2 network plus the update) at the same batch;
  beat     A2C runs of ``experiments/pong.py`` with ``--train-envs`` games and each of ``--seeds``,
           ``--lr`` (default 2e-3: the learning-rate sweep of BENCHMARKS.md, "jaxpg's Pong") and
           ``--t-max``, each trained for ``--seconds`` of wall clock (compilation excluded) or
           exactly ``--iterations``: when the seed's running reward first exceeds each of
           ``--thresholds`` (0: the agent beats the scripted opponent on average; 10: by 10 points
           of 21);
  compare  MinPy's comparison, ``--compare-envs 1 2 4 16 ...``: the same A2C runs with each number
           of envs (the experiment's learning rate unless ``--lr`` is given, no fps measurement),
           and their running reward against wall clock in ``RUN_DIR/pong_envs.png``: more envs
           learn faster in wall-clock time (docs/benchmarks_archive.md, section J). ``--algo ppo``
           runs the same comparison with PPO (the experiment's settings, e.g. PPO's Atari recipe
           on the ROM, which learns there faster than MinPy's A2C: BENCHMARKS.md, "Atari Pong on
           the ROM").

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

This script holds the command line; the measurements live in ``benchmarks/pong_modes/``.
``python benchmarks/pong.py atari-fps`` measures the frames per second of the Atari ROM's paths
instead (``atari-fps --help``).
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import jax
from pong_modes import atari_fps, fps, plots, runs

from jaxpg.run.command import command_line, flags, planning
from jaxpg.run.host import compile_cache


def build_parser() -> argparse.ArgumentParser:
    parser = command_line.Parser(
        prog="python benchmarks/pong.py",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="\n\n".join(__doc__.split("\n\n")[1:]),
    )
    parser.add_argument("--task", choices=sorted(runs.EXPERIMENTS), default="pong", help="atari_pong: the ROM, in ALE")
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
        return atari_fps.atari_fps_main(argv[1:])
    try:
        args = build_parser().parse_args(argv)
        if args.plot:
            plots.plot_files(args.plot[1:], args.plot[0])
            return 0
        compare = args.compare_envs is not None
        args.fps_envs = args.fps_envs if args.fps_envs is not None else ([] if compare else [1024, 4096])
        check(args)
        root = args.run_dir or Path("runs") / f"pong-benchmark-{datetime.datetime.now():%Y%m%d-%H%M%S}"
        experiment = runs.load_experiment(args.task)
        budget = dict(
            seconds=args.seconds, iterations=args.iterations, size=args.size, call_steps=args.call_steps, algo=args.algo
        )
        plans = [
            planning.plan(
                runs.run_argv(
                    root / runs.run_name(n, t_max, lr, seed, args.algo), args.task, n, seed, lr, t_max, **budget
                ),
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
            "env": fps.env_fps(n, args.horizon, size),
            "a2c": fps.train_fps(n, size),
            "a2c_scan": fps.train_fps(n, size, per_call=args.scan),
        }
        fps_rows.append(row)
        print(
            f"fps envs={n}: env {row['env']['fps']:,.0f}/s, A2C training {row['a2c']['fps']:,.0f}/s "
            f"(scan of {args.scan}: {row['a2c_scan']['fps']:,.0f}/s)",
            flush=True,
        )
    beat_rows = []
    for plan in plans:
        runs.train_run(plan)
        beat_rows.append(runs.summarize(plan.run_dir, args.thresholds))

    game = f"jaxpg Pong ({size}x{size} frame differences)" if args.task == "pong" else "Atari Pong (ALE)"
    if compare:
        plots.plot(beat_rows, root / "pong_envs.png", f"{args.algo.upper()} on {game}, {device}")
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


if __name__ == "__main__":
    sys.exit(main())
