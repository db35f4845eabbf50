"""jaxpg's tasks through the Gymnasium API, for code written against Gymnasium (Stable-Baselines3,
CleanRL, your own loops).

    env = jaxpg.envs.gymnasium_env("hopper")              # gymnasium.make("jaxpg/Hopper-v5")
    vec = jaxpg.envs.gymnasium_vector_env("hopper", 4096)  # all envs in one jitted call

``gymnasium_env`` is a single ``gymnasium.Env`` made through ``gymnasium.make`` (so with
Gymnasium's ``TimeLimit``, order enforcing and passive checker), registered as
``jaxpg/Hopper-v5``, ``jaxpg/InvertedPendulum-v5``, ``jaxpg/InvertedDoublePendulum-v5``,
``jaxpg/HalfCheetah-v5``, ``jaxpg/Swimmer-v5``, ``jaxpg/Walker2d-v5``, ``jaxpg/Reacher-v5`` and
``jaxpg/CartPole-v1`` once this module is imported.

``gymnasium_vector_env`` is a ``gymnasium.vector.VectorEnv`` that steps every env in one jitted,
``vmap``-ed call on one device, with Gymnasium's *same-step* autoreset
(``AutoresetMode.SAME_STEP``): when an episode ends, ``step`` returns the next episode's first
observation, and ``info["final_obs"]`` (an object array, ``None`` where no episode ended, with
the mask ``info["_final_obs"]``) holds the observation the episode ended in, for bootstrapping
a truncated episode. ``terminated`` and ``truncated`` follow Gymnasium's ``TimeLimit``: an
episode that reaches its step limit is truncated, even when its last step also terminated it.

Both follow jaxpg's task semantics (Gymnasium v5 rewards, terminations and observations, in
``fidelity="fast"`` physics by default: pass ``fidelity="gymnasium"`` for Gymnasium's own
integrator and solver settings). Observations are float32, continuous actions float32 in the
task's range (clipped, as Gymnasium's MuJoCo envs clip in the simulator), CartPole's actions
integers 0 or 1. Seeds: ``reset(seed=s)`` makes the same episodes for the same ``s``; a list of
seeds (one per env) seeds each env on its own.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from jaxpg import envs as envs_lib

# Gymnasium id -> (jaxpg task, Gymnasium's step limit for it)
GYMNASIUM_IDS: dict[str, tuple[str, int]] = {
    "jaxpg/Hopper-v5": ("hopper", 1000),
    "jaxpg/InvertedPendulum-v5": ("inverted_pendulum", 1000),
    "jaxpg/InvertedDoublePendulum-v5": ("inverted_double_pendulum", 1000),
    "jaxpg/HalfCheetah-v5": ("half_cheetah", 1000),
    "jaxpg/Swimmer-v5": ("swimmer", 1000),
    "jaxpg/Pusher-v5": ("pusher", 100),
    "jaxpg/Walker2d-v5": ("walker2d", 1000),
    "jaxpg/Humanoid-v5": ("humanoid", 1000),
    "jaxpg/Reacher-v5": ("reacher", 50),
    "jaxpg/Ant-v5": ("ant", 1000),
    "jaxpg/CartPole-v1": ("cartpole", 500),
}


def task_spaces(env: envs_lib.Env) -> tuple[spaces.Space, spaces.Space]:
    """``(observation_space, action_space)`` of one env of a jaxpg task: a float32 ``Box`` of
    ``[observation_size]`` unbounded, and a float32 ``Box`` of ``[action_size]`` in the task's
    range (``Discrete(action_size)`` for a discrete task)."""
    obs_space = spaces.Box(-np.inf, np.inf, (env.observation_size,), np.float32)
    if env.discrete:
        return obs_space, spaces.Discrete(env.action_size)
    act_space = spaces.Box(env.action_low, env.action_high, (env.action_size,), np.float32)
    return obs_space, act_space


def _check_actions(actions: Any, space: spaces.Space, batch: int | None) -> np.ndarray:
    """``actions`` as a NumPy array of the space's dtype and shape (with a leading ``batch`` axis
    when given), or ``ValueError`` with one line saying what was expected."""
    where = "" if batch is None else f" for {batch} envs"
    arr = np.asarray(actions)
    if isinstance(space, spaces.Discrete):
        expected: tuple[int, ...] = () if batch is None else (batch,)
        if arr.shape != expected or not np.issubdtype(arr.dtype, np.integer):
            raise ValueError(
                f"expected integer actions of shape {expected}{where} in [0, {space.n}), got {arr.dtype} {arr.shape}"
            )
        if np.any((arr < 0) | (arr >= space.n)):
            raise ValueError(f"actions must be in [0, {space.n}), got {arr.min()}..{arr.max()}")
        return arr.astype(np.int32)
    expected = tuple(space.shape) if batch is None else (batch, *space.shape)
    if arr.shape != expected or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise ValueError(f"expected real actions of shape {expected}{where}, got {arr.dtype} {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("actions must be finite (got NaN or inf)")
    return arr.astype(np.float32)


def _render_one(env: envs_lib.Env, state: envs_lib.State) -> np.ndarray:
    """``[H, W, 3] uint8`` frame of one (unbatched) ``state``."""
    from jaxpg import video

    data = state.data
    qpos = np.asarray(data.qpos)[None] if hasattr(data, "qpos") else None
    qvel = np.asarray(data.qvel)[None] if hasattr(data, "qvel") else None
    return video.render_states(env, np.asarray(state.obs)[None], qpos, qvel)[0]


@functools.lru_cache(maxsize=16)
def _single_env(task: str, make_items: tuple) -> tuple[envs_lib.Env, Callable, Callable]:
    """The env and its jitted ``reset``/``step``, shared by every ``JaxpgEnv`` of the same task and
    arguments (so a second env, e.g. a checker's or an evaluation env, compiles nothing)."""
    env = envs_lib.make_shared(task, **dict(make_items))
    return env, jax.jit(env.reset), jax.jit(env.step)


@functools.lru_cache(maxsize=16)
def _vector_env(task: str, make_items: tuple, num_envs: int) -> tuple[envs_lib.Env, Callable, Callable]:
    """The env and the jitted batched ``reset``/``step`` of ``JaxpgVectorEnv``, shared likewise."""
    make_kwargs = dict(make_items)
    env = envs_lib.make_shared(task, batch=num_envs, **make_kwargs)
    sampler = envs_lib.AutoReset(env)
    step = jax.jit(lambda state, actions: _vector_step(sampler, env.max_episode_steps, state, actions))
    return env, jax.jit(jax.vmap(sampler.reset)), step


def _items(make_kwargs: dict[str, Any]) -> tuple:
    return tuple(sorted(make_kwargs.items()))


class JaxpgEnv(gymnasium.Env):
    """One jaxpg task as a ``gymnasium.Env`` (module docstring); jitted ``reset`` and ``step``.

    Make it through ``gymnasium_env`` (or ``gymnasium.make("jaxpg/...")``), which adds
    Gymnasium's ``TimeLimit``; the bare class also stops at the task's own limit.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, task: str, render_mode: str | None = None, **make_kwargs: Any):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.task = task
        self.env, self._reset_fn, self._step_fn = _single_env(task, _items(make_kwargs))
        self.observation_space, self.action_space = task_spaces(self.env)
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": max(1, round(1.0 / self.env.dt))}
        self._key: jax.Array | None = None
        self._state: envs_lib.State | None = None

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        if seed is not None or self._key is None:
            start = seed if seed is not None else int(self.np_random.integers(2**31))
            self._key = jax.random.PRNGKey(start)
        self._key, key = jax.random.split(self._key)
        self._state = self._reset_fn(key)
        return np.array(self._state.obs), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        action = _check_actions(action, self.action_space, None)
        self._state = self._step_fn(self._state, jnp.asarray(action))
        s = self._state
        return np.array(s.obs), float(s.reward), bool(s.terminated), bool(s.truncated), {}

    def render(self) -> np.ndarray | None:
        if self.render_mode is None or self._state is None:
            return None
        return _render_one(self.env, self._state)


def _register() -> None:
    for gym_id, (task, limit) in GYMNASIUM_IDS.items():
        if gym_id not in gymnasium.registry:
            gymnasium.register(
                gym_id, entry_point=f"{__name__}:JaxpgEnv", kwargs={"task": task}, max_episode_steps=limit
            )


_register()


def gymnasium_id(name: str) -> str:
    """The Gymnasium id of jaxpg task ``name`` (``"hopper"`` -> ``"jaxpg/Hopper-v5"``)."""
    for gym_id, (task, _) in GYMNASIUM_IDS.items():
        if task == name or gym_id == name:
            return gym_id
    known = ", ".join(task for task, _ in GYMNASIUM_IDS.values())
    raise ValueError(f"no Gymnasium id for {name!r}; tasks with one: {known}")


def gymnasium_env(name: str, **make_kwargs: Any) -> gymnasium.Env:
    """``gymnasium.make`` of jaxpg task ``name`` (or its id, e.g. ``"jaxpg/Hopper-v5"``):
    Gymnasium's wrappers around ``JaxpgEnv``; ``make_kwargs`` go to the env (``render_mode``,
    ``fidelity``, ``impl``, ...)."""
    return gymnasium.make(gymnasium_id(name), **make_kwargs)


class JaxpgVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` envs of a jaxpg task, stepped in one jitted call on one device (module
    docstring). ``array_type="numpy"`` returns NumPy arrays; ``"jax"`` returns ``jax.Array``s
    left on the device (share them without a copy through DLPack, e.g. ``torch.from_dlpack``).
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": ["rgb_array"]}

    def __init__(
        self,
        name: str,
        num_envs: int,
        device: jax.Device | None = None,
        render_mode: str | None = None,
        array_type: str = "numpy",
        **make_kwargs: Any,
    ):
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        if array_type not in ("numpy", "jax"):
            raise ValueError(f"array_type must be 'numpy' or 'jax', got {array_type!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        task = GYMNASIUM_IDS[name][0] if name in GYMNASIUM_IDS else name
        env, self._reset_fn, self._step_fn = _vector_env(task, _items(make_kwargs), num_envs)
        self.task, self.env, self.num_envs = task, env, num_envs
        self.device = device or jax.devices()[0]
        self.array_type = array_type
        self.render_mode = render_mode
        self.single_observation_space, self.single_action_space = task_spaces(env)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.metadata = {**self.metadata, "render_fps": max(1, round(1.0 / env.dt))}
        self._key: jax.Array | None = None
        self._state: envs_lib.State | None = None

    def _out(self, x: jax.Array) -> Any:
        return np.array(x) if self.array_type == "numpy" else x

    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None) -> tuple[Any, dict[str, Any]]:
        """Reset every env. ``seed``: one int (the envs' keys are split from it), a list of
        ``num_envs`` ints (one per env), or ``None`` (continue the current key stream)."""
        super().reset(seed=seed if isinstance(seed, int) or seed is None else None)
        if isinstance(seed, list | tuple):
            if len(seed) != self.num_envs:
                raise ValueError(f"expected {self.num_envs} seeds, got {len(seed)}")
            keys = jnp.stack([jax.random.PRNGKey(s) for s in seed])
        else:
            if seed is not None or self._key is None:
                start = seed if seed is not None else int(self.np_random.integers(2**31))
                self._key = jax.random.PRNGKey(start)
            self._key, key = jax.random.split(self._key)
            keys = jax.random.split(key, self.num_envs)
        self._state = self._reset_fn(jax.device_put(keys, self.device))
        return self._out(self._state.obs), {}

    def step(self, actions: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        if self.array_type == "jax" and isinstance(actions, jax.Array):
            checked = actions  # trusted on the device; shapes are still checked by the env when traced
        else:
            checked = jax.device_put(_check_actions(actions, self.single_action_space, self.num_envs), self.device)
        self._state, (obs, reward, terminated, truncated, final_obs) = self._step_fn(self._state, checked)
        info: dict[str, Any] = {}
        done = np.asarray(terminated | truncated)
        if done.any():
            final = np.asarray(final_obs)
            array = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(done):
                array[i] = final[i]
            info = {"final_obs": array, "_final_obs": done}
        return self._out(obs), self._out(reward), self._out(terminated), self._out(truncated), info

    def render(self) -> np.ndarray | None:
        """A frame of env 0 (``render_mode="rgb_array"``)."""
        if self.render_mode is None or self._state is None:
            return None
        first = jax.tree.map(lambda x: x[0], self._state)
        return _render_one(self.env, first)


def _vector_step(
    sampler: envs_lib.Env, limit: int, state: envs_lib.State, actions: jax.Array
) -> tuple[envs_lib.State, tuple[jax.Array, ...]]:
    """One vmapped step of the auto-resetting ``sampler``: the new state and ``(obs, reward,
    terminated, truncated, final_obs)``, ``[num_envs, ...]``; ``truncated`` as Gymnasium's
    ``TimeLimit`` has it (true at the ``limit``-th step of an episode, terminated or not)."""
    steps_before = state.info["step"]
    new = jax.vmap(sampler.step)(state, actions)
    truncated = new.truncated | (steps_before + 1 >= limit)
    return new, (new.obs, new.reward, new.terminated, truncated, new.info["final_obs"])


def gymnasium_vector_env(
    name: str, num_envs: int, device: jax.Device | None = None, **make_kwargs: Any
) -> JaxpgVectorEnv:
    """A ``gymnasium.vector.VectorEnv`` of ``num_envs`` envs of jaxpg task ``name`` (or its
    Gymnasium id) on ``device`` (default: JAX's first); ``make_kwargs`` go to ``JaxpgVectorEnv``
    (``render_mode``, ``array_type``) and to the task (``fidelity``, ``impl``, ...)."""
    if name not in GYMNASIUM_IDS and name not in envs_lib.names():
        raise ValueError(f"unknown environment {name!r}; known environments: {', '.join(envs_lib.names())}")
    return JaxpgVectorEnv(name, num_envs, device=device, **make_kwargs)
