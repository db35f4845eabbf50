"""A trained policy replayed in the reference implementations: Gymnasium's CPU env of the task
(``Hopper-v5`` ...) and, for Pong, the real Atari game (ALE's ``ALE/Pong-v5``)."""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from typing import Any

import numpy as np

from jaxpg import envs
from jaxpg import video as video_lib
from jaxpg.envs import atari
from jaxpg.run.command import task_options

GYMNASIUM_INSTALL = "pip install 'gymnasium[mujoco]'"


def gymnasium_counterpart(task: str) -> str | None:
    """The id of Gymnasium's env that ``task`` reproduces (``"Hopper-v5"``), or ``None``
    (``jaxpg.envs.GYMNASIUM_COUNTERPARTS``)."""
    counterpart = envs.GYMNASIUM_COUNTERPARTS.get(task)
    return None if counterpart is None else counterpart[0]


def gymnasium_installed() -> bool:
    """Gymnasium can be imported (``GYMNASIUM_INSTALL`` says how to install it otherwise)."""
    try:  # Gymnasium is an optional extra: this module imports without it
        import gymnasium  # noqa: F401
    except ImportError:
        return False
    return True


def gymnasium_reference_env(task: str, env_kwargs: dict[str, Any], render: bool = False) -> Any:
    """The Gymnasium env matching a jaxpg task (same time limit). Raises ``ImportError`` with the
    install command when Gymnasium is missing."""
    try:  # an optional extra, as above
        import gymnasium as gym
    except ImportError:
        raise ImportError(f"Gymnasium is not installed: {GYMNASIUM_INSTALL}") from None

    gym_id = gymnasium_counterpart(task)
    if gym_id is None:
        known = ", ".join(envs.GYMNASIUM_COUNTERPARTS)
        raise ValueError(f"task {task!r} has no Gymnasium counterpart; known: {known}")
    kwargs = gymnasium_options(task, gym_id, env_kwargs)
    if "max_episode_steps" in env_kwargs:
        kwargs["max_episode_steps"] = int(env_kwargs["max_episode_steps"])
    if render and task != "cartpole":  # CartPole's renderer needs pygame; jaxpg draws it itself
        kwargs.update(render_mode="rgb_array", width=480, height=480)
    return gym.make(gym_id, **kwargs)


def gymnasium_parameters(gym_id: str) -> dict[str, inspect.Parameter]:
    """The keyword arguments of the class that Gymnasium registers as ``gym_id`` (its entry point),
    with their defaults."""
    import gymnasium as gym

    module_name, _, class_name = str(gym.spec(gym_id).entry_point).partition(":")
    return dict(inspect.signature(getattr(importlib.import_module(module_name), class_name)).parameters)


def gymnasium_options(task: str, gym_id: str, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """The task options among ``env_kwargs`` (``jaxpg.run.command.task_options``, e.g. Ant's
    ``include_cfrc_ext_in_observation``), which Gymnasium's ``gym_id`` takes with the same meaning;
    ``ValueError`` for one that it does not take (a replay without it would score another task).
    The simulation settings (fidelity, implementation, batch) are jaxpg's own and stay out."""
    options = {k: v for k, v in env_kwargs.items() if k in task_options.option_types(task)}
    missing = sorted(set(options) - set(gymnasium_parameters(gym_id)))
    if missing:
        raise ValueError(f"Gymnasium's {gym_id} has no option {', '.join(missing)}, which this run's env was given")
    return options


def evaluate_gymnasium(
    policy: Callable[[np.ndarray], np.ndarray],
    task: str,
    env_kwargs: dict[str, Any],
    episodes: int,
    seed: int = 0,
    video: str | None = None,
    configure_model: Callable[[Any], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """``(returns [N], lengths [N], frames of the first episode)`` of ``policy`` in Gymnasium.

    ``configure_model``: called with the env's MuJoCo model before the first episode (e.g. to
    change its physics settings, as ``benchmarks/suite.py physics`` does)."""
    env = gymnasium_reference_env(task, env_kwargs, render=video is not None)
    if configure_model is not None:
        configure_model(env.unwrapped.model)
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
    return atari.play_ale(policy, episodes, action_set, sticky=sticky, seed=seed)
