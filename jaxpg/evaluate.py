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
the most probable one.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

GYMNASIUM_INSTALL = "pip install 'gymnasium[mujoco]'"
GYMNASIUM_IDS = {
    "hopper": "Hopper-v5",
    "inverted_pendulum": "InvertedPendulum-v5",
    "inverted_double_pendulum": "InvertedDoublePendulum-v5",
    "half_cheetah": "HalfCheetah-v5",
    "swimmer": "Swimmer-v5",
    "walker2d": "Walker2d-v5",
    "humanoid": "Humanoid-v5",
    "reacher": "Reacher-v5",
    "ant": "Ant-v5",
    "pusher": "Pusher-v5",
    "cartpole": "CartPole-v1",
}


class Episodes:
    """NumPy results of ``rollout``: ``E`` episodes of up to ``T`` steps.

    Attributes:
      rewards: ``[T, E]`` (0 after an episode's end); valid: ``[T, E]`` 1 up to and including
      the last step; returns, lengths: ``[E]``; obs: ``[T + 1, E, obs_dim]`` states from the
      reset on; qpos, qvel: ``[T + 1, E, nq/nv]`` for MJX tasks, else ``None``;
      task_score: ``[E]`` the task's score (``Env.task_score_name``) at each episode's end.
    """

    def __init__(self, out: dict[str, np.ndarray]):
        self.rewards = out["rewards"]
        self.valid = out["valid"]
        self.obs, self.qpos, self.qvel = out["obs"], out.get("qpos"), out.get("qvel")
        self.returns = np.sum(self.rewards * self.valid, axis=0)
        self.lengths = np.sum(self.valid, axis=0).astype(np.int64)
        self.task_score = out["task_score"]

    def episode_states(self, i: int) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """``(obs, qpos, qvel)`` of episode ``i``, from its reset to its last state (``[L + 1, ...]``)."""
        n = int(self.lengths[i]) + 1
        pick = lambda x: None if x is None else x[:n, i]
        return self.obs[:n, i], pick(self.qpos), pick(self.qvel)


def physics_states(state: Any) -> dict[str, Any]:
    """What a video needs of each state ``[B]``: ``obs``, and ``qpos``, ``qvel`` for MJX tasks
    (a ``record_fn`` of ``jaxpg.rollout``)."""
    out = {"obs": state.obs}
    if hasattr(state.data, "qpos") and hasattr(state.data, "qvel"):
        out["qpos"], out["qvel"] = state.data.qpos, state.data.qvel
    return out


def _rollout_impl(env: Any, policy: Any, num_episodes: int, horizon: int, deterministic: bool) -> Callable:
    """The jitted ``(params, obs_stats, key) -> {name: array}`` behind ``rollout``: an episodic
    ``jaxpg.rollout`` of the policy (its mode, or samples) that records the physics states."""
    import jax
    import jax.numpy as jnp

    from jaxpg import rollout as rollout_lib
    from jaxpg.algos.core import make_act

    def run(params: Any, obs_stats: Any, key: jax.Array) -> dict[str, jax.Array]:
        reset_key, steps_key = jax.random.split(key)  # as rollout_lib.rollout_episodes splits it
        state = rollout_lib.reset_batch(env, reset_key, num_episodes)
        act = make_act(policy, obs_stats, deterministic)
        traj = rollout_lib.rollout_episodes_from(env, act, params, state, steps_key, horizon, physics_states)
        return {
            "rewards": traj.rewards,
            "valid": traj.valid,
            **rollout_lib.with_initial(physics_states(state), traj.extras),
            "task_score": rollout_lib.last_valid(traj, traj.metrics["task_score"].astype(jnp.float32)),
        }

    return jax.jit(run)


_COMPILED: dict[tuple, Callable] = {}


def rollout(
    env: Any,
    policy: Any,
    params: Any,
    obs_stats: Any,
    seed: int | Any = 0,
    num_episodes: int = 10,
    horizon: int | None = None,
    deterministic: bool = True,
) -> Episodes:
    """``num_episodes`` episodes of ``policy`` in the jaxpg env ``env``, in parallel (jitted once
    per env, policy and shape). ``horizon`` defaults to the env's time limit."""
    import jax

    horizon = int(horizon or env.max_episode_steps)
    cache_key = (env, policy, num_episodes, horizon, deterministic)
    if cache_key not in _COMPILED:
        _COMPILED[cache_key] = _rollout_impl(env, policy, num_episodes, horizon, deterministic)
    key = jax.random.PRNGKey(seed) if isinstance(seed, int) else seed
    out = jax.device_get(_COMPILED[cache_key](params, obs_stats, key))
    return Episodes({k: np.asarray(v) for k, v in out.items()})


def record_policy(
    env: Any,
    policy: Any,
    params: Any,
    obs_stats: Any,
    path: str | Path,
    seed: int = 0,
    max_steps: int | None = None,
) -> tuple[Path, float, int]:
    """Roll out the mean policy for one episode (``rollout``) and save its video
    (``video.save_episode_video``); returns ``(path, episode
    return, episode length)``."""
    from jaxpg import video as video_lib

    horizon = int(max_steps or env.max_episode_steps)
    episodes = rollout(env, policy, params, obs_stats, seed, num_episodes=1, horizon=horizon)
    length = int(episodes.lengths[0])
    obs, qpos, qvel = episodes.episode_states(0)
    out = video_lib.save_episode_video(env, obs, qpos, qvel, path)
    return out, float(episodes.returns[0]), length


def gymnasium_installed() -> bool:
    """Gymnasium can be imported (``GYMNASIUM_INSTALL`` says how to install it otherwise)."""
    try:
        import gymnasium  # noqa: F401
    except ImportError:
        return False
    return True


def gymnasium_env(task: str, env_kwargs: dict[str, Any], render: bool = False) -> Any:
    """The Gymnasium env matching a jaxpg task (same time limit). Raises ``ImportError`` with the
    install command when Gymnasium is missing."""
    try:
        import gymnasium as gym
    except ImportError:
        raise ImportError(f"Gymnasium is not installed: {GYMNASIUM_INSTALL}") from None

    if task not in GYMNASIUM_IDS:
        raise ValueError(f"task {task!r} has no Gymnasium counterpart; known: {', '.join(GYMNASIUM_IDS)}")
    kwargs: dict[str, Any] = {}
    if "max_episode_steps" in env_kwargs:
        kwargs["max_episode_steps"] = int(env_kwargs["max_episode_steps"])
    if render and task != "cartpole":  # CartPole's renderer needs pygame; jaxpg draws it itself
        kwargs.update(render_mode="rgb_array", width=480, height=480)
    return gym.make(GYMNASIUM_IDS[task], **kwargs)


def evaluate_gymnasium(
    policy: Callable[[np.ndarray], np.ndarray],
    task: str,
    env_kwargs: dict[str, Any],
    episodes: int,
    seed: int = 0,
    video: str | None = None,
) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """``(returns [N], lengths [N], frames of the first episode)`` of ``policy`` in Gymnasium."""
    from jaxpg import video as video_lib

    env = gymnasium_env(task, env_kwargs, render=video is not None)
    returns, lengths, frames = [], [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i)
        total, steps, done = 0.0, 0, False
        while not done:
            if video is not None and i == 0:
                frames.append(env.render() if task != "cartpole" else video_lib.draw_cartpole(obs))
            action = policy(obs)
            if task == "cartpole":
                action = int(action)
            obs, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            steps += 1
            done = terminated or truncated
        if video is not None and i == 0:
            frames.append(env.render() if task != "cartpole" else video_lib.draw_cartpole(obs))
        returns.append(total)
        lengths.append(steps)
    env.close()
    return np.asarray(returns), np.asarray(lengths), frames


def ale_action_set(task: str, env_kwargs: dict[str, Any]) -> str:
    """The ``jaxpg.envs.atari.ACTION_SETS`` entry that maps a Pong run's actions to ALE's
    (``ValueError``, one line, for a task that cannot play ``ALE/Pong-v5``)."""
    if task == "atari_pong":
        return str(env_kwargs.get("action_set", "updown"))
    if task == "pong":  # jaxpg's own Pong: {up, down} or {stay, up, down} on 80x80 frame differences
        if int(env_kwargs.get("size", 80)) != 80:
            raise ValueError(f"--ale needs 80x80 frames; this pong run used size {env_kwargs['size']}")
        return "stay" if env_kwargs.get("stay_action") else "updown"
    raise ValueError(f"--ale plays Atari Pong: task {task!r} is not a Pong task (atari_pong or pong)")


def evaluate_ale(
    policy: Callable[[np.ndarray], np.ndarray], action_set: str, episodes: int, sticky: bool, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """``(scores [N], lengths [N])`` of ``policy`` in Gymnasium's ``ALE/Pong-v5``
    (``jaxpg.envs.atari.play_ale``)."""
    from jaxpg.envs import atari

    return atari.play_ale(policy, episodes, action_set, sticky=sticky, seed=seed)


def _stats(x: np.ndarray) -> str:
    return f"{np.mean(x):.2f} ± {np.std(x):.2f}"


def _video_problem(run: Any, gymnasium: bool) -> str | None:
    """Why the video of ``run``'s task cannot be rendered here (one line), or ``None``. Only tasks
    drawn by MuJoCo's OpenGL renderer can fail; CartPole and Pong are drawn with NumPy."""
    from jaxpg import video as video_lib

    if gymnasium:
        needs_gl = run.task != "cartpole"
    else:
        task = run.make_env().unwrapped
        needs_gl = hasattr(task, "mj_model") and not hasattr(task, "render_frame")
    return video_lib.gl_problem() if needs_gl else None


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


def main(argv: Sequence[str] | None = None) -> int:
    from jaxpg import video as video_lib
    from jaxpg.run.flags import UsageError, check_backend, seed_value

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
    parser.add_argument("--video", metavar="OUT", help="render the first episode to OUT (.mp4 or .gif)")
    parser.add_argument("--step", default="latest", help="checkpoint: 'latest' (default), 'best' or an iteration")
    parser.add_argument("--seed", type=seed_value, default=0, help="seed of the evaluation episodes (default: 0)")
    parser.add_argument("--train-seed", type=seed_value, help="which of the run's training seeds (default: the first)")
    args = parser.parse_args(argv)
    if args.video:  # MuJoCo is not imported yet: choose a GL backend that loads, only for a video
        video_lib.configure_gl()
    if args.episodes < 1:
        print("error: --episodes must be >= 1", file=sys.stderr)
        return 2
    if args.video and Path(args.video).suffix.lower() not in (".mp4", ".gif"):
        print(f"error: --video must end in .mp4 or .gif, got {args.video!r}", file=sys.stderr)
        return 2
    if args.gymnasium and not gymnasium_installed():
        print(f"error: --gymnasium needs Gymnasium: {GYMNASIUM_INSTALL}", file=sys.stderr)
        return 2
    if args.ale and (args.gymnasium or args.video):
        print("error: --ale plays ALE/Pong-v5 alone: drop --gymnasium and --video", file=sys.stderr)
        return 2
    problem = output_problem(Path(args.video)) if args.video else None
    if problem is not None:  # checked before the evaluation, which may take long
        print(f"error: --video {args.video}: {problem}", file=sys.stderr)
        return 2
    try:
        check_backend()
    except UsageError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    try:
        from jaxpg.run import policy_io

        if args.ale:
            from jaxpg.envs import atari

            atari.require_ale()
        policy = policy_io.load_policy(
            args.run_dir, args.step, seed=args.train_seed, deterministic=not args.sample, sample_seed=args.seed
        )
        action_set = ale_action_set(policy.run.task, policy.run.env_kwargs) if args.ale else None
    except (ValueError, ImportError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    run = policy.run
    kind = "sampled actions" if args.sample else "mean policy"
    where = f"checkpoint step {policy.step} of {args.run_dir} (seed {policy.seed}), {kind}"
    if args.ale:
        scores, lengths = evaluate_ale(policy, action_set, args.episodes, args.sticky, args.seed)
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
        if run.task not in GYMNASIUM_IDS:
            print(f"error: task {run.task!r} has no Gymnasium counterpart", file=sys.stderr)
            return 2
        returns, lengths, frames = evaluate_gymnasium(
            policy, run.task, run.env_kwargs, args.episodes, args.seed, video=args.video
        )
        env_name = f"Gymnasium {GYMNASIUM_IDS[run.task]}"
        metric_line = ""
    else:
        env = run.make_env()
        eps = rollout(
            env, policy.policy, policy.params, policy.obs_stats, args.seed, args.episodes, deterministic=not args.sample
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
