"""Evaluate a trained policy: ``python -m jaxpg.evaluate RUN_DIR --episodes N [--gymnasium | --ale] [--video out.mp4]``.

By default the run's mean (deterministic) policy plays ``N`` episodes of jaxpg's own env (the
task and env settings the run trained on, all episodes in parallel). ``--gymnasium`` plays them
in the corresponding Gymnasium CPU env instead (``Hopper-v5``, ``InvertedPendulum-v5``,
``InvertedDoublePendulum-v5``, ``HalfCheetah-v5``, ``Swimmer-v5``, ``Walker2d-v5``, ``Reacher-v5``,
``CartPole-v1``), through ``jaxpg.load_policy``: a check that the policy transfers to the
reference implementation. Prints mean and std of return and length.
``--ale`` plays a Pong policy (``atari_pong``, or jaxpg's own ``pong`` at 80x80) in the real Atari
game, Gymnasium's ``ALE/Pong-v5``, with its sticky actions (``--no-sticky``: none), and prints the
mean score (points won minus lost, -21 to 21); ``--sample`` samples the actions instead of taking
the most probable one. ``--mean-action`` says how a continuous policy's mean policy acts:
``mode`` (``clip(mean)``) or ``clipped_mean`` (``E[clip(a)]``, the mean of the actions the clipped
task executes: a wide Gaussian's mean action is clipped far more often than its samples average
out); by default as the run's own evaluations did (its ``eval_action``).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg import video as video_lib
from jaxpg.run.command.flags import UsageError, check_backend, seed_value


def _stats(x: np.ndarray) -> str:
    return f"{np.mean(x):.2f} ± {np.std(x):.2f}"


def _video_problem(run: Any, gymnasium: bool) -> str | None:
    """Why the video of ``run``'s task cannot be rendered here (one line), or ``None``. Only tasks
    drawn by MuJoCo's OpenGL renderer can fail; CartPole and Pong are drawn with NumPy."""
    if gymnasium:
        needs_gl = run.task != "cartpole"
    else:
        task = run.make_env().unwrapped
        needs_gl = hasattr(task, "mj_model") and not hasattr(task, "render_frame")
    return video_lib.gl_problem() if needs_gl else None


def leave_out_warp_if_unused(run_dir: str) -> None:
    """Before MJX is imported: import it without MuJoCo Warp (``jaxpg.envs.mjx_import``) when the
    run's env will step on MJX's JAX implementation here (the run asked for ``impl="jax"``, or for
    none and JAX has no GPU). A run directory that cannot be read is left to the evaluation to
    report. Imports what it needs itself: ``--help`` stays quick."""
    import jax

    from jaxpg.envs import mjx_import
    from jaxpg.run.command import startup

    if startup.saved_run_steps_mjx_on_jax_only(run_dir, jax.default_backend()):
        mjx_import.leave_out_warp()


def output_problem(path: Path) -> str | None:
    """Why no file can be written at ``path`` (one short line), or ``None`` when one can: its
    nearest existing ancestor must be a writable directory (tried by creating and removing a
    temporary file or directory there) and ``path`` itself no directory. Leaves nothing behind."""
    try:
        if path.is_dir():
            return "it is a directory"
        existing = path.parent
        while not existing.exists() and existing != existing.parent:
            existing = existing.parent
        if not existing.is_dir():
            return f"{existing} is not a directory"
        if path.exists():
            with path.open("ab"):  # opened for appending, nothing written: the file is unchanged
                pass
        elif existing == path.parent:
            fd, tmp = tempfile.mkstemp(dir=existing, prefix=".jaxpg-write-test-")
            os.close(fd)
            os.unlink(tmp)
        else:
            os.rmdir(tempfile.mkdtemp(dir=existing, prefix=".jaxpg-write-test-"))
    except OSError as e:
        return f"cannot write there ({e.strerror or e})"
    return None


def main(argv: Sequence[str] | None = None, owns_process: bool = False) -> int:
    """``python -m jaxpg.evaluate``; returns the exit status. ``owns_process``: nothing but this
    command runs in the process (its script's own call), so that MJX may be imported without
    MuJoCo Warp when the evaluation will not use it (``leave_out_warp_if_unused``) and JAX may take
    GPU memory on demand (``startup.allocate_gpu_memory_on_demand``)."""
    parser = argparse.ArgumentParser(
        prog="python -m jaxpg.evaluate",
        description=__doc__.split("\n\n")[0].split(": ", 1)[-1] if __doc__ else None,
        epilog="Example: python -m jaxpg.evaluate runs/pendulum --episodes 20 --gymnasium --video pendulum.mp4",
    )
    parser.add_argument("run_dir", help="a run directory written by jaxpg.cli / experiments/*.py")
    parser.add_argument("--episodes", type=int, default=10, help="number of episodes (default: 10)")
    parser.add_argument("--gymnasium", action="store_true", help="play in the Gymnasium CPU env instead of jaxpg's")
    parser.add_argument("--ale", action="store_true", help="play a Pong policy in the real Atari game, ALE/Pong-v5")
    parser.add_argument(
        "--sticky",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="with --ale: ALE/Pong-v5's sticky actions (repeat probability 0.25); --no-sticky: none",
    )
    parser.add_argument("--sample", action="store_true", help="sample actions instead of the most probable one")
    parser.add_argument(
        "--mean-action",
        choices=("mode", "clipped_mean"),
        help="how the mean policy of a continuous task acts: mode, clip(mean); clipped_mean, E[clip(a)] under the "
        "Gaussian policy, the mean of the actions the clipped task executes (default: as the run's evaluations did)",
    )
    parser.add_argument("--video", metavar="OUT", help="render the first episode to OUT (.mp4 or .gif)")
    parser.add_argument("--step", default="latest", help="checkpoint: 'latest' (default), 'best' or an iteration")
    parser.add_argument("--seed", type=seed_value, default=0, help="seed of the evaluation episodes (default: 0)")
    parser.add_argument("--train-seed", type=seed_value, help="which of the run's training seeds (default: the first)")
    args = parser.parse_args(argv)
    if args.video:  # MuJoCo is not imported yet: choose a GL backend that loads, only for a video
        video_lib.configure_gl()
    # Here, once the arguments parse: the policy's modules bring JAX's training stack (flax, optax),
    # a large part of what --help would take with them.
    from jaxpg.envs import atari
    from jaxpg.run.checkpoints import policy_io
    from jaxpg.run.evaluation import policy_episodes, replay

    if args.episodes < 1:
        print("error: --episodes must be >= 1", file=sys.stderr)
        return 2
    if args.video and Path(args.video).suffix.lower() not in (".mp4", ".gif"):
        print(f"error: --video must end in .mp4 or .gif, got {args.video!r}", file=sys.stderr)
        return 2
    if args.gymnasium and not replay.gymnasium_installed():
        print(f"error: --gymnasium needs Gymnasium: {replay.GYMNASIUM_INSTALL}", file=sys.stderr)
        return 2
    if args.mean_action and (args.sample or args.ale):
        print(
            "error: --mean-action is how the mean policy of a continuous task acts: drop --sample and --ale",
            file=sys.stderr,
        )
        return 2
    if args.ale and (args.gymnasium or args.video):
        print("error: --ale plays ALE/Pong-v5 alone: drop --gymnasium and --video", file=sys.stderr)
        return 2
    problem = output_problem(Path(args.video)) if args.video else None
    if problem is not None:  # checked before the evaluation, which may take long
        print(f"error: --video {args.video}: {problem}", file=sys.stderr)
        return 2
    if owns_process:
        from jaxpg.run.command import startup

        startup.allocate_gpu_memory_on_demand()  # before JAX starts its GPU backend
    try:
        check_backend()
    except UsageError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if owns_process:
        leave_out_warp_if_unused(args.run_dir)
    try:
        if args.ale:
            atari.require_ale()
        policy = policy_io.load_policy(
            args.run_dir,
            args.step,
            seed=args.train_seed,
            deterministic=not args.sample,
            sample_seed=args.seed,
            clipped_mean=None if args.mean_action is None else args.mean_action == "clipped_mean",
        )
        action_set = replay.ale_action_set(policy.run.task, policy.run.env_kwargs) if args.ale else None
    except (ValueError, ImportError) as e:
        from jaxpg.run.rundir.config_io import error_lines

        for line in error_lines(e):  # one per bad value of a config.json
            print(f"error: {line}", file=sys.stderr)
        return 2
    run = policy.run
    kind = "sampled actions" if args.sample else "mean policy, clipped mean" if policy.clipped_mean else "mean policy"
    where = f"checkpoint step {policy.step} of {args.run_dir} (seed {policy.seed}), {kind}"
    if args.ale:
        scores, lengths = replay.evaluate_ale(policy, action_set, args.episodes, args.sticky, args.seed)
        sticky = "sticky actions 0.25" if args.sticky else "repeat_action_probability=0"
        print(f"{where}, {args.episodes} games of ALE/Pong-v5 ({sticky})")
        print(f"score: {_stats(scores)}  (min {np.min(scores):+.0f}, max {np.max(scores):+.0f}; points won - lost)")
        print(f"length: {_stats(lengths)} steps (4 frames each)")
        print(f"mean score: {np.mean(scores):+.2f}")
        return 0
    problem = _video_problem(run, args.gymnasium) if args.video else None
    if problem is not None:
        print(f"error: --video: {problem}", file=sys.stderr)
        return 2
    if args.gymnasium:
        gym_id = replay.gymnasium_counterpart(run.task)
        if gym_id is None:
            print(f"error: task {run.task!r} has no Gymnasium counterpart", file=sys.stderr)
            return 2
        try:  # the run's task options, given to Gymnasium's env too
            options = replay.gymnasium_options(run.task, gym_id, run.env_kwargs)
        except ValueError as e:
            print(f"error: --gymnasium: {e}", file=sys.stderr)
            return 2
        returns, lengths, frames = replay.evaluate_gymnasium(
            policy, run.task, run.env_kwargs, args.episodes, args.seed, video=args.video
        )
        env_name = f"Gymnasium {gym_id}" + "".join(f" {k}={v}" for k, v in options.items())
        metric_line = ""
    else:
        env = run.make_env()
        eps = policy_episodes.play_episodes(
            env,
            policy.policy,
            policy.params,
            policy.obs_stats,
            args.seed,
            args.episodes,
            deterministic=not args.sample,
            clipped_mean=policy.clipped_mean,
        )
        returns, lengths = eps.returns, eps.lengths
        env_name = f"jaxpg {run.task}" + (f" {run.env_kwargs}" if run.env_kwargs else "")
        metric_line = ""
        if env.task_score_name != "return":
            metric_line = f"\n{env.task_score_name}: {_stats(eps.task_score)}"
    print(f"{where}, {args.episodes} episodes in {env_name}")
    print(f"return: {_stats(returns)}  (min {np.min(returns):.2f}, max {np.max(returns):.2f})")
    print(f"length: {_stats(lengths)}{metric_line}")
    if args.video:
        try:
            if args.gymnasium:
                env = run.make_env()
                stride, fps = video_lib.frame_stride(float(env.dt))
                out = video_lib.write_video(frames[::stride], args.video, fps)
            else:
                obs, qpos, qvel = eps.episode_states(0)
                out = video_lib.save_episode_video(env, obs, qpos, qvel, args.video)
        except video_lib.RenderError as e:
            print(f"error: no video: {e}", file=sys.stderr)
            return 1
        print(f"video of episode 1: {out}")
    return 0 if all(math.isfinite(float(r)) for r in returns) else 1


if __name__ == "__main__":
    raise SystemExit(main())
