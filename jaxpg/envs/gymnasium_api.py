"""jaxpg's tasks through the Gymnasium API, for code written against Gymnasium (Stable-Baselines3,
CleanRL, Gymnasium's own wrappers and vector envs, your own loops). ``docs/gymnasium.md`` is the
user's guide; this docstring is the contract.

    env = gymnasium.make("jaxpg/Hopper-v5")              # Gymnasium's Hopper-v5, simulated by MJX
    env = gymnasium.make("jaxpg/HopperFast-v5")          # the same task in jaxpg's fast physics
    vec = gymnasium.make_vec("jaxpg/Hopper-v5", 4096)    # all envs in one jitted call

Ids. Importing this module registers ``jaxpg/<Id>`` for every Gymnasium env jaxpg has a task of
(``GYMNASIUM_IDS``). Such an id behaves like Gymnasium's ``<Id>`` by default: Gymnasium's physics
(``fidelity="gymnasium"``: the model's own integrator and solver), its observation and action
spaces (float64 observations for the MuJoCo tasks, CartPole's bounded float32 box), its spec (time
limit, ``reward_threshold``) and its ``info`` keys (``INFO_KEYS``). jaxpg's fast physics (Euler, a
short Newton solve; an order of magnitude faster on a GPU, and no longer step-for-step Gymnasium's)
is one explicit choice: the id ``jaxpg/<Name>Fast-v<N>`` (``fast_id``), which a script that takes
only an id can name, or ``fidelity="fast"`` given to ``gymnasium.make``.

In Gymnasium's physics the single env's ``reset(seed)`` draws Gymnasium's start state from
``np_random`` (``gymnasium_mujoco``); rewards and ``info`` values have the types of Gymnasium's
env (``gymnasium_spaces.REWARD_TYPES``), and ``env.unwrapped`` has ``MujocoEnv``'s ``data``,
``model``, ``dt``, ``frame_skip``, ``init_qpos``, ``init_qvel`` and ``state_vector()``. Every
process that makes an env turns jaxpg's persistent compilation cache on
(``gymnasium_spaces.enable_compile_cache``). ``gymnasium_registration`` registers the ids without
importing jaxpg, for a start-up hook in scripts that never import it.

Time limits are Gymnasium's ``TimeLimit``'s alone: ``gymnasium.make(id, max_episode_steps=n)``
truncates at ``n``, above the registered limit too (the single env has no limit of its own).

``gymnasium.make_vec(id, n)`` reaches ``JaxpgVectorEnv`` (the ids' ``vector_entry_point``), which
steps all ``n`` envs in one jitted, ``vmap``-ed call on one device; ``vectorization_mode="sync"``
and ``"async"`` build Gymnasium's own vector envs of single envs, and work with no extra
arguments: a single env made in a process forked after JAX started (``AsyncVectorEnv``'s default
``fork`` context, where JAX would deadlock) runs in a fresh interpreter of its own and forwards
every call there.

Autoreset. ``JaxpgVectorEnv`` takes ``autoreset_mode``: ``NEXT_STEP`` (Gymnasium's default, so
its vector wrappers such as ``NormalizeObservation`` compose: the step after an episode ends
ignores its action and returns the next episode's first observation with reward 0) or
``SAME_STEP`` (the step that ends an episode returns the next episode's first observation, and
``info["final_obs"]`` / ``info["final_info"]`` hold the ended episode's last observation and
info, masked by ``info["_final_obs"]`` / ``info["_final_info"]``). ``truncated`` follows
``TimeLimit``: true at the limit's step even when that step also terminated.

Single envs pickle and deep-copy (the copy continues the same episode); a closed env refuses to
``reset`` and ``step``. Continuous actions are clipped to the action space, as Gymnasium's MuJoCo
envs clip in the simulator; bad actions raise a one-line ``ValueError``.
"""

from __future__ import annotations

from typing import Any

import gymnasium

from jaxpg import envs as envs_lib
from jaxpg.envs import gymnasium_registration
from jaxpg.envs.gymnasium_single import MUJOCO_ATTRIBUTES, REFUSED_KEYWORDS, JaxpgEnv, check_keywords, serve
from jaxpg.envs.gymnasium_spaces import (  # the version check runs first
    DATA_INFO,
    GYMNASIUM_IDS,
    INFO_KEYS,
    MIN_GYMNASIUM,
    NO_FIDELITY,
    check_gymnasium_version,
    fast_id,
    info_arrays,
)
from jaxpg.envs.gymnasium_vector import JaxpgVectorEnv, gymnasium_vector_env, make_vector

__all__ = [
    "DATA_INFO",
    "GYMNASIUM_IDS",
    "INFO_KEYS",
    "MIN_GYMNASIUM",
    "MUJOCO_ATTRIBUTES",
    "NO_FIDELITY",
    "REFUSED_KEYWORDS",
    "JaxpgEnv",
    "JaxpgVectorEnv",
    "check_gymnasium_version",
    "check_keywords",
    "fast_id",
    "gymnasium_env",
    "gymnasium_id",
    "gymnasium_vector_env",
    "info_arrays",
    "make_vector",
    "serve",
]


def _task_classes(task: str, theirs: str) -> tuple[type, type]:
    """``<Name>Env`` and ``<Name>VectorEnv`` of ``task`` (Gymnasium's id ``theirs``): the ids'
    entry points, ``JaxpgEnv`` and ``JaxpgVectorEnv`` of the task in Gymnasium's physics unless
    given ``fidelity``, so that the ids' ``spec.kwargs`` are Gymnasium's."""
    default = {} if task in NO_FIDELITY else {"fidelity": "gymnasium"}

    def init_env(self: JaxpgEnv, render_mode: str | None = None, **kwargs: Any) -> None:
        JaxpgEnv.__init__(self, task, render_mode=render_mode, **{**default, **kwargs})

    def init_vector(self: JaxpgVectorEnv, num_envs: int, **kwargs: Any) -> None:
        JaxpgVectorEnv.__init__(self, task, num_envs, **{**default, **kwargs})

    name = gymnasium_registration.class_name(theirs)
    env_doc = f"``JaxpgEnv`` of task {task!r}: the entry point of ``jaxpg/{theirs}`` and its fast id."
    vector_doc = f"``JaxpgVectorEnv`` of task {task!r}: the vector entry point of ``jaxpg/{theirs}``."
    env_class = type(name, (JaxpgEnv,), {"__init__": init_env, "__module__": __name__, "__doc__": env_doc})
    vector_name = name.removesuffix("Env") + "VectorEnv"
    vector_class = type(
        vector_name, (JaxpgVectorEnv,), {"__init__": init_vector, "__module__": __name__, "__doc__": vector_doc}
    )
    return env_class, vector_class


for _task, (_theirs, _) in envs_lib.GYMNASIUM_COUNTERPARTS.items():
    for _class in _task_classes(_task, _theirs):
        globals()[_class.__name__] = _class


def gymnasium_id(name: str, fidelity: str = "gymnasium") -> str:
    """The Gymnasium id of jaxpg task ``name`` (``"hopper"`` -> ``"jaxpg/Hopper-v5"``;
    ``fidelity="fast"`` -> ``"jaxpg/HopperFast-v5"``); a jaxpg id is returned as it is."""
    if fidelity not in ("gymnasium", "fast"):
        raise ValueError(f"unknown fidelity {fidelity!r}: expected 'gymnasium' or 'fast'")
    for gym_id, (task, _) in GYMNASIUM_IDS.items():
        ids = (gym_id,) if task in NO_FIDELITY else (gym_id, fast_id(gym_id))
        if name in ids:
            return name
        if name == task:
            return ids[-1] if fidelity == "fast" else gym_id
    known = ", ".join(task for task, _ in GYMNASIUM_IDS.values())
    raise ValueError(f"no Gymnasium id for {name!r}; tasks with one: {known}")


def gymnasium_env(name: str, **make_kwargs: Any) -> gymnasium.Env:
    """``gymnasium.make`` of jaxpg task ``name`` (or its id, e.g. ``"jaxpg/Hopper-v5"``):
    Gymnasium's wrappers around ``JaxpgEnv``; ``make_kwargs`` go to ``gymnasium.make`` and the
    env (``render_mode``, ``max_episode_steps``, ``fidelity``, ``impl``, ...)."""
    return gymnasium.make(gymnasium_id(name), **make_kwargs)


gymnasium_registration.register_ids(gymnasium)
