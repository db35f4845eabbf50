"""Episodes of a trained policy in jaxpg's own env (one jitted program per env, policy and
shape, all episodes in parallel), and a video of one."""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxpg import rollout as rollout_lib
from jaxpg import video as video_lib
from jaxpg.algos.core import make_act
from jaxpg.envs import compile_options


class Episodes:
    """NumPy results of ``play_episodes``: ``E`` episodes of up to ``T`` steps.

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


@functools.lru_cache(maxsize=32)
def _rollout_impl(
    env: Any, policy: Any, num_episodes: int, horizon: int, deterministic: bool, clipped_mean: bool = False
) -> Callable:
    """The jitted ``(params, obs_stats, key) -> {name: array}`` behind ``play_episodes``: an episodic
    ``jaxpg.rollout`` of the policy (its mode, its clipped mean, or samples) that records the
    physics states."""

    def run(params: Any, obs_stats: Any, key: jax.Array) -> dict[str, jax.Array]:
        reset_key, steps_key = jax.random.split(key)  # as rollout_lib.rollout_episodes splits it
        state = rollout_lib.reset_batch(env, reset_key, num_episodes)
        bounds = (float(env.action_low), float(env.action_high)) if clipped_mean else None
        act = make_act(policy, obs_stats, deterministic, clipped_mean_bounds=bounds)
        traj = rollout_lib.rollout_episodes_from(env, act, params, state, steps_key, horizon, physics_states)
        return {
            "rewards": traj.rewards,
            "valid": traj.valid,
            **rollout_lib.with_initial(physics_states(state), traj.extras),
            "task_score": rollout_lib.last_valid(traj, traj.metrics["task_score"].astype(jnp.float32)),
        }

    return compile_options.jit(run, env)


def play_episodes(
    env: Any,
    policy: Any,
    params: Any,
    obs_stats: Any,
    seed: int | Any = 0,
    num_episodes: int = 10,
    horizon: int | None = None,
    deterministic: bool = True,
    clipped_mean: bool = False,
) -> Episodes:
    """``num_episodes`` episodes of ``policy`` in the jaxpg env ``env``, in parallel (jitted once
    per env, policy and shape). ``horizon`` defaults to the env's time limit. ``clipped_mean``:
    act with ``E[clip(a)]`` under the Gaussian policy (``core.make_act``) in place of its mode."""
    horizon = int(horizon or env.max_episode_steps)
    key = jax.random.PRNGKey(seed) if isinstance(seed, int) else seed
    rollout = _rollout_impl(env, policy, num_episodes, horizon, deterministic, clipped_mean)
    out = jax.device_get(rollout(params, obs_stats, key))
    return Episodes({k: np.asarray(v) for k, v in out.items()})


def record_policy(
    env: Any,
    policy: Any,
    params: Any,
    obs_stats: Any,
    path: str | Path,
    seed: int = 0,
    max_steps: int | None = None,
    clipped_mean: bool = False,
) -> tuple[Path, float, int]:
    """Roll out the mean policy for one episode (``play_episodes``; its clipped mean with
    ``clipped_mean``) and save its video (``video.save_episode_video``); returns ``(path, episode
    return, episode length)``."""
    horizon = int(max_steps or env.max_episode_steps)
    episodes = play_episodes(
        env, policy, params, obs_stats, seed, num_episodes=1, horizon=horizon, clipped_mean=clipped_mean
    )
    length = int(episodes.lengths[0])
    obs, qpos, qvel = episodes.episode_states(0)
    out = video_lib.save_episode_video(env, obs, qpos, qvel, path)
    return out, float(episodes.returns[0]), length
