"""jaxpg environments: pure, jittable, ``vmap``-able tasks with Gymnasium v5 semantics.

    env = jaxpg.envs.make("hopper")            # fast MJX physics, warp on a GPU when available
    state = env.reset(jax.random.key(0))
    state = env.step(state, action)

``make`` returns the task wrapped in ``ClipAction`` (continuous tasks) and ``EpisodeStats``; the
continuing sampler in ``jaxpg.rollout`` adds ``AutoReset``.
"""

from __future__ import annotations

import importlib
from typing import Any

from jaxpg.envs.base import Env, State
from jaxpg.envs.wrappers import AutoReset, ClipAction, EpisodeStats, Wrapper

# name -> "module:Class", imported on first use so that `import jaxpg` stays cheap.
REGISTRY: dict[str, str] = {
    "hopper": "jaxpg.envs.hopper:Hopper",
    "inverted_pendulum": "jaxpg.envs.inverted_pendulum:InvertedPendulum",
    "inverted_double_pendulum": "jaxpg.envs.inverted_double_pendulum:InvertedDoublePendulum",
    "cartpole": "jaxpg.envs.cartpole:CartPole",
    "pong": "jaxpg.envs.pong:Pong",
}


def names() -> list[str]:
    """The names ``make`` accepts, sorted."""
    return sorted(REGISTRY)


def make_task(name: str, **kwargs: Any) -> Env:
    """The bare task ``name`` with no wrappers. Raises ``ValueError`` for an unknown name."""
    if name not in REGISTRY:
        raise ValueError(f"unknown environment {name!r}; known environments: {', '.join(names())}")
    module_name, class_name = REGISTRY[name].split(":")
    cls = getattr(importlib.import_module(module_name), class_name)
    return cls(**kwargs)


def make(name: str, **kwargs: Any) -> Env:
    """Task ``name`` with action clipping and episode statistics.

    ``kwargs`` go to the task, e.g. ``fidelity="gymnasium"``, ``impl="jax"``,
    ``max_episode_steps=500``. Raises ``ValueError`` listing the known names for an unknown one.
    """
    return EpisodeStats(ClipAction(make_task(name, **kwargs)))


__all__ = ["AutoReset", "ClipAction", "Env", "EpisodeStats", "State", "Wrapper", "make", "make_task", "names"]
