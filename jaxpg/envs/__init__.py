"""jaxpg environments: pure, jittable, ``vmap``-able tasks with Gymnasium v5 semantics.

    env = jaxpg.envs.make("hopper")            # fast MJX physics, warp on a GPU when available
    state = env.reset(jax.random.key(0))
    state = env.step(state, action)

``make`` returns the task wrapped in ``ClipAction`` (continuous tasks) and ``EpisodeStats``; the
continuing sampler in ``jaxpg.rollout`` adds ``AutoReset``. ``make(name, action_scaling=True)``
puts ``RescaleAction`` under ``ClipAction``: actions in ``[-1, 1]`` on every continuous task.
"""

from __future__ import annotations

import functools
import importlib
import sys
from typing import Any

from jaxpg.envs.base import Env, State
from jaxpg.envs.tasks import GYMNASIUM_COUNTERPARTS, REGISTRY, Task, register, unregister
from jaxpg.envs.wrappers import AutoReset, ClipAction, EpisodeStats, RescaleAction, Wrapper

# The tasks (jaxpg.envs.tasks, one ``Task`` each): REGISTRY (name -> "module:Class", imported on
# first use so that `import jaxpg` stays cheap) and GYMNASIUM_COUNTERPARTS (task -> Gymnasium's id
# and step limit) are views of that table.


def names() -> list[str]:
    """The names ``make`` accepts, sorted."""
    return sorted(REGISTRY)


def make_task(name: str, **kwargs: Any) -> Env:
    """The bare task ``name`` with no wrappers. Raises ``ValueError`` for an unknown name."""
    return task_class(name)(**kwargs)


def task_class(name: str) -> type:
    """The class registered as ``name`` (imported on first use), or for a name with a colon
    (``brax:ant``, ``playground:CheetahRun``, ``module:Class``) the one ``jaxpg.envs.brax_task``
    resolves. ``ValueError`` for an unknown name."""
    if name not in REGISTRY and ":" in name:
        from jaxpg.envs import brax_task

        return brax_task.task_class(name)
    if name not in REGISTRY:
        raise ValueError(f"unknown environment {name!r}; known environments: {', '.join(names())}")
    module_name, class_name = REGISTRY[name].split(":")
    return getattr(importlib.import_module(module_name), class_name)


def warp_capacity(name: str, env_kwargs: dict[str, Any], batch: int) -> dict[str, Any]:
    """``{"max_batch": batch}`` (at least MJX's default 8192) for an MJX task on MuJoCo Warp, whose
    contact buffer is sized for the whole vmapped batch (``MjxEnv``); ``{}`` otherwise. Pass it to
    ``make`` with the task's other ``env_kwargs`` when ``batch`` envs will step together."""
    if not is_mjx(name):
        return {}
    from jaxpg.envs.mjx_env import default_impl  # already imported: the task is MJX's

    warp = (env_kwargs.get("impl") or default_impl()) == "warp"
    return {"max_batch": max(batch, 8192)} if warp else {}


def is_mjx(name: str) -> bool:
    """Whether task ``name`` runs on MJX (its class subclasses ``jaxpg.envs.mjx_env.MjxEnv``).
    Imports the task's own module only: for CartPole and Pong, MuJoCo (with MJX and MuJoCo Warp,
    seconds to import) stays unimported. ``ValueError`` for an unknown name."""
    task = task_class(name)
    # MjxEnv's subclasses exist only after its module ran: if it has not, this task is none of them.
    mjx_env = sys.modules.get("jaxpg.envs.mjx_env")
    return mjx_env is not None and issubclass(task, mjx_env.MjxEnv)


def gymnasium_env(name: str, **make_kwargs: Any) -> Any:
    """Task ``name`` as a single ``gymnasium.Env`` (``gymnasium.make("jaxpg/Hopper-v5")``); see
    ``jaxpg.envs.gymnasium_api``. Needs Gymnasium (``pip install gymnasium``)."""
    return _gymnasium_api().gymnasium_env(name, **make_kwargs)


def gymnasium_vector_env(name: str, num_envs: int, device: Any = None, **make_kwargs: Any) -> Any:
    """``num_envs`` envs of task ``name`` as one ``gymnasium.vector.VectorEnv`` stepped in a jitted
    call; see ``jaxpg.envs.gymnasium_api``. Needs Gymnasium (``pip install gymnasium``)."""
    return _gymnasium_api().gymnasium_vector_env(name, num_envs, device=device, **make_kwargs)


def _gymnasium_api() -> Any:
    try:
        import gymnasium  # noqa: F401
    except ImportError:
        raise ImportError("jaxpg's Gymnasium API needs Gymnasium: pip install 'gymnasium>=1.1'") from None
    from jaxpg.envs import gymnasium_api

    return gymnasium_api


def make(name: str, batch: int | None = None, action_scaling: bool = False, **kwargs: Any) -> Env:
    """Task ``name`` with action clipping and episode statistics.

    ``batch``: the most envs that will step together in one vmapped call (all nested vmaps, e.g.
    envs x seeds); the physics backend sizes its buffers for it (MuJoCo Warp's contact buffer is
    shared by the whole batch; see ``warp_capacity``). Omit it for batches up to 8192.
    ``kwargs`` go to the task, e.g. ``fidelity="gymnasium"``, ``impl="jax"``,
    ``max_episode_steps=500``. ``action_scaling``: the env takes actions in ``[-1, 1]``, mapped
    onto the task's range (``RescaleAction``; ``ValueError`` for a discrete task). Raises
    ``ValueError`` listing the known names for an unknown one.
    """
    if batch is not None:
        if not isinstance(batch, int) or batch < 1:
            raise ValueError(f"batch must be a positive integer, got {batch!r}")
        kwargs = {**warp_capacity(name, kwargs, batch), **kwargs}
    task = make_task(name, **kwargs)
    return EpisodeStats(ClipAction(RescaleAction(task) if action_scaling else task))


@functools.cache
def _shared(name: str, batch: int | None, items: tuple[tuple[str, Any], ...]) -> Env:
    return make(name, batch=batch, **dict(items))


def make_shared(name: str, batch: int | None = None, **kwargs: Any) -> Env:
    """``make``, returning the same env object for the same arguments (made once per process).

    Envs are immutable and are static arguments of jitted functions (hashed by identity), so a
    second run, evaluation or Gymnasium env of the same task in one process (a resume, a test, a
    notebook) reuses the programs compiled for the first instead of compiling them again.
    """
    return _shared(name, batch, tuple(sorted(kwargs.items())))


__all__ = [
    "GYMNASIUM_COUNTERPARTS",
    "REGISTRY",
    "AutoReset",
    "ClipAction",
    "Env",
    "EpisodeStats",
    "RescaleAction",
    "State",
    "Task",
    "Wrapper",
    "gymnasium_env",
    "gymnasium_vector_env",
    "is_mjx",
    "make",
    "make_shared",
    "make_task",
    "names",
    "register",
    "unregister",
    "warp_capacity",
]
