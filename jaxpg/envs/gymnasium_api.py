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

import functools
from collections.abc import Callable
from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np

from jaxpg import envs as envs_lib
from jaxpg.envs import compile_options, gymnasium_worker
from jaxpg.envs.gymnasium_spaces import (  # the version check runs first
    DATA_INFO,
    GYMNASIUM_IDS,
    INFO_KEYS,
    MIN_GYMNASIUM,
    NO_FIDELITY,
    NO_LIMIT,
    check_actions,
    check_gymnasium_version,
    fast_id,
    gymnasium_observation_space,
    host_info,
    info_arrays,
    make_key,
    render_one,
    task_spaces,
)
from jaxpg.envs.gymnasium_vector import JaxpgVectorEnv, gymnasium_vector_env, make_vector

__all__ = [
    "DATA_INFO",
    "GYMNASIUM_IDS",
    "INFO_KEYS",
    "MIN_GYMNASIUM",
    "NO_FIDELITY",
    "JaxpgEnv",
    "JaxpgVectorEnv",
    "check_gymnasium_version",
    "fast_id",
    "gymnasium_env",
    "gymnasium_id",
    "gymnasium_vector_env",
    "info_arrays",
    "make_vector",
    "serve",
]


@functools.lru_cache(maxsize=32)
def _single_env(task: str, make_items: tuple) -> tuple[envs_lib.Env, Callable, Callable]:
    """The env and its jitted ``reset``/``step``, shared by every ``JaxpgEnv`` of the same task and
    arguments (so a second env, e.g. a checker's or an evaluation env, compiles nothing)."""
    env = envs_lib.make_shared(task, **dict(make_items))
    return env, compile_options.jit(env.reset, env), compile_options.jit(env.step, env)


@functools.lru_cache(maxsize=32)
def _set_state_fn(env: envs_lib.Env) -> Callable:
    """Jitted ``(qpos, qvel) -> mjx.Data`` of ``env``'s MJX task, with derived quantities."""
    task = env.unwrapped
    return compile_options.jit(lambda qpos, qvel: task.physics_state(qpos, qvel, forward=True), task)


def serve(read_fd: int, write_fd: int) -> None:
    """The loop of a ``gymnasium_worker.Worker``'s process (the pipes' file descriptors): make the
    env, then answer calls until ``close``."""
    from multiprocessing.connection import Connection

    inbox, outbox = Connection(read_fd, writable=False), Connection(write_fd, readable=False)
    try:
        env = JaxpgEnv(**inbox.recv())
        outbox.send((True, (env.observation_space, env.action_space, env.metadata)))
    except Exception as error:  # noqa: BLE001 - handed to the parent, which raises it
        outbox.send((False, error))
        return
    while True:
        try:
            name, args, kwargs = inbox.recv()
        except EOFError:
            return
        try:
            outbox.send((True, getattr(env, name)(*args, **kwargs)))
        except Exception as error:  # noqa: BLE001
            outbox.send((False, error))
        if name == "close":
            return


class JaxpgEnv(gymnasium.Env):
    """One jaxpg task as a ``gymnasium.Env`` (module docstring); jitted ``reset`` and ``step``.

    Make it through ``gymnasium.make("jaxpg/...")`` (or ``gymnasium_env``), which adds
    Gymnasium's ``TimeLimit``; the bare class never truncates. ``make_kwargs`` go to the task
    (``fidelity``, ``impl``, reward weights ...).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, task: str, render_mode: str | None = None, **make_kwargs: Any):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if task not in INFO_KEYS:
            raise ValueError(f"no Gymnasium env for task {task!r}; tasks with one: {', '.join(INFO_KEYS)}")
        self.task = task
        self.render_mode = render_mode
        self._make_kwargs = {"max_episode_steps": NO_LIMIT, **make_kwargs}
        self._state: envs_lib.State | None = None
        self._closed = False
        self._worker: gymnasium_worker.Worker | None = None
        self._start()

    def _start(self) -> None:
        """Make (or fetch) the compiled env here, or start a worker process after a fork."""
        if gymnasium_worker.forked_after_jax():
            kwargs = {"task": self.task, "render_mode": self.render_mode, **self._make_kwargs}
            self._worker = gymnasium_worker.Worker(kwargs)
            self.observation_space, self.action_space, self.metadata = self._worker.spaces
            return
        self.env, self._reset_fn, self._step_fn = _single_env(self.task, make_key(self._make_kwargs))
        _, self.action_space = task_spaces(self.env)
        self.observation_space = gymnasium_observation_space(self.task, self.env.observation_size)
        self.metadata = {**type(self).metadata, "render_fps": max(1, round(1.0 / self.env.dt))}

    def _check_open(self) -> None:
        """``RuntimeError`` once ``close`` was called."""
        if self._closed:
            raise RuntimeError(f"this {self.task} env is closed: make a new one")

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        self._check_open()
        if self._worker is not None:
            return self._worker.call("reset", seed=seed, options=options)
        super().reset(seed=seed)
        if seed is not None:
            key = jax.random.PRNGKey(seed)
        elif self._state is not None:
            key = self._state.info["rng"]  # the episode's key for the next reset, as in the vector env
        else:
            key = jax.random.PRNGKey(int(self.np_random.integers(2**31)))
        self._state = self._reset_fn(key)
        obs, info = jax.device_get((self._state.obs, info_arrays(self.task, self._state)))
        return self._observation(obs), host_info(info, INFO_KEYS[self.task][0])

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        self._check_open()
        if self._worker is not None:
            return self._worker.call("step", action)
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        action = check_actions(action, self.action_space, None)
        self._state = s = self._step_fn(self._state, jnp.asarray(action))
        obs, reward, terminated, truncated, info = jax.device_get(
            (s.obs, s.reward, s.terminated, s.truncated, info_arrays(self.task, s))
        )
        info = host_info(info, INFO_KEYS[self.task][1])
        return self._observation(obs), float(reward), bool(terminated), bool(truncated), info

    def _observation(self, obs: np.ndarray) -> np.ndarray:
        return np.asarray(obs, dtype=self.observation_space.dtype)

    def set_state(self, qpos: Any, qvel: Any) -> None:
        """Set an MJX task's joint positions ``qpos [nq]`` and velocities ``qvel [nv]``, as
        Gymnasium's ``MujocoEnv.set_state`` does (the next ``step`` starts from them)."""
        self._check_open()
        if self._worker is not None:
            return self._worker.call("set_state", qpos, qvel)
        task = self.env.unwrapped
        if not hasattr(task, "physics_state") or self._state is None:
            raise RuntimeError(f"set_state needs a MuJoCo task after reset(); {self.task} is not one or was not reset")
        qpos, qvel = np.asarray(qpos), np.asarray(qvel)
        if qpos.shape != (task.nq,) or qvel.shape != (task.nv,):
            raise ValueError(
                f"expected qpos of shape ({task.nq},) and qvel ({task.nv},), got {qpos.shape} {qvel.shape}"
            )
        self._state = self._state.replace(data=_set_state_fn(self.env)(qpos, qvel))
        return None

    def render(self) -> np.ndarray | None:
        self._check_open()
        if self._worker is not None:
            return self._worker.call("render")
        if self.render_mode is None or self._state is None:
            return None
        return render_one(self.env, self._state)

    def close(self) -> None:
        """Release the env; ``reset`` and ``step`` raise ``RuntimeError`` afterwards."""
        if self._worker is not None:
            self._worker.close()
            self._worker = None
        self._closed = True
        super().close()

    def __getstate__(self) -> dict[str, Any]:
        """Everything but the compiled functions, with the episode's state as NumPy arrays."""
        if self._worker is not None:
            raise TypeError("a JaxpgEnv running in a worker process (made after a fork) cannot be pickled")
        skip = ("env", "_reset_fn", "_step_fn", "_worker")
        state = {k: v for k, v in self.__dict__.items() if k not in skip}
        state["_state"] = jax.device_get(self._state)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._worker = None
        if not self._closed:
            self._start()


def _register() -> None:
    """Register ``jaxpg/<Id>`` (Gymnasium's physics) and ``fast_id`` of it for every id."""
    for gym_id, (task, limit) in GYMNASIUM_IDS.items():
        theirs = gym_id.split("/", 1)[1]
        threshold = gymnasium.spec(theirs).reward_threshold if theirs in gymnasium.registry else None
        variants = (
            {gym_id: {}}
            if task in NO_FIDELITY
            else {gym_id: {"fidelity": "gymnasium"}, fast_id(gym_id): {"fidelity": "fast"}}
        )
        for variant, fidelity in variants.items():
            if variant not in gymnasium.registry:
                gymnasium.register(
                    variant,
                    entry_point=f"{__name__}:JaxpgEnv",
                    vector_entry_point=f"{__name__}:make_vector",
                    kwargs={"task": task, **fidelity},
                    max_episode_steps=limit,
                    reward_threshold=threshold,
                )


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


_register()
