"""jaxpg's batched ``gymnasium.vector.VectorEnv``: every env of a task stepped in one jitted,
``vmap``-ed call on one device, with Gymnasium's next-step or same-step autoreset
(``gymnasium_api``'s docstring has the contract).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from jaxpg import envs as envs_lib
from jaxpg.envs import compile_options, gymnasium_registration
from jaxpg.envs.gymnasium_spaces import (
    GYMNASIUM_IDS,
    INFO_KEYS,
    check_actions,
    enable_compile_cache,
    gymnasium_observation_space,
    info_arrays,
    make_key,
    render_one,
    seed_key,
    task_spaces,
)


def _select(env: envs_lib.Env, pick_new: jax.Array, new: envs_lib.State, old: envs_lib.State) -> envs_lib.State:
    """``new`` where the scalar ``pick_new`` (one env, inside ``vmap``) else ``old``; the physics
    state as ``env``'s automatic reset selects it."""
    data = env.select_physics(pick_new, new.data, old.data)
    rest = jax.tree.map(lambda n, o: jnp.where(pick_new, n, o), new.replace(data=None), old.replace(data=None))
    return rest.replace(data=data)


def _vector_step(
    env: envs_lib.Env, task: str, mode: AutoresetMode, state: envs_lib.State, actions: jax.Array
) -> tuple[envs_lib.State, dict[str, Any]]:
    """One batched step of ``JaxpgVectorEnv`` (to ``vmap``): the new state and its outputs
    (``obs``, ``reward``, ``terminated``, ``truncated``, ``info``, ``reset`` (a new episode began
    here); in ``SAME_STEP`` mode also ``final_obs`` and ``final_info``). ``truncated`` as
    Gymnasium's ``TimeLimit`` has it: true at ``env.max_episode_steps``, terminated or not."""
    stepped = env.step(state, actions)
    limit_hit = state.info["step"] + 1 >= env.max_episode_steps
    stepped = stepped.replace(truncated=stepped.truncated | limit_hit)
    if mode == AutoresetMode.NEXT_STEP:
        restart = state.terminated | state.truncated  # the last step ended an episode
        new = _select(env, restart, env.reset(state.info["rng"]), stepped)
        out = {"obs": new.obs, "reward": new.reward, "terminated": new.terminated, "truncated": new.truncated}
        return new, {**out, "info": info_arrays(task, new), "reset": restart}
    done = stepped.terminated | stepped.truncated
    new = _select(env, done, env.reset(stepped.info["rng"]), stepped)
    out = {"obs": new.obs, "reward": stepped.reward, "terminated": stepped.terminated, "truncated": stepped.truncated}
    finals = {"final_obs": stepped.obs, "final_info": info_arrays(task, stepped)}
    return new, {**out, "info": info_arrays(task, new), "reset": done, **finals}


@functools.lru_cache(maxsize=16)
def _vector_env(
    task: str, make_items: tuple, num_envs: int, mode: AutoresetMode
) -> tuple[envs_lib.Env, Callable, Callable]:
    """The env and the jitted batched ``reset``/``step`` of ``JaxpgVectorEnv``, shared likewise."""
    env = envs_lib.make_shared(task, batch=num_envs, **dict(make_items))
    step = compile_options.jit(jax.vmap(functools.partial(_vector_step, env, task, mode)), env)
    return env, compile_options.jit(jax.vmap(env.reset), env), step


def _batched_info(values: dict[str, np.ndarray], keys: tuple[str, ...], mask: np.ndarray) -> dict[str, Any]:
    """Gymnasium's vector ``info`` of ``keys``: ``info[k]`` the values of every env and
    ``info["_k"]`` where they hold."""
    info: dict[str, Any] = {}
    for k in keys:
        info[k] = np.asarray(values[k], np.float64)
        info[f"_{k}"] = mask
    return info


class JaxpgVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` envs of a jaxpg task, stepped in one jitted call on one device (module
    docstring). ``array_type="numpy"`` returns NumPy arrays, observations in the Gymnasium env's
    dtype; ``"jax"`` returns ``jax.Array``s left on the device (float32 observations; share them
    without a copy through DLPack, e.g. ``torch.from_dlpack``). The task's ``max_episode_steps``
    (``make_kwargs``) is the time limit.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": ["rgb_array"]}

    def __init__(
        self,
        name: str,
        num_envs: int,
        device: jax.Device | None = None,
        render_mode: str | None = None,
        array_type: str = "numpy",
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        **make_kwargs: Any,
    ):
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        if array_type not in ("numpy", "jax"):
            raise ValueError(f"array_type must be 'numpy' or 'jax', got {array_type!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        modes = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP)
        if autoreset_mode not in modes and autoreset_mode not in [m.value for m in modes]:
            raise ValueError(f"autoreset_mode must be AutoresetMode.NEXT_STEP or SAME_STEP, got {autoreset_mode!r}")
        mode = AutoresetMode(autoreset_mode)
        task = GYMNASIUM_IDS[name][0] if name in GYMNASIUM_IDS else name
        enable_compile_cache()
        env, self._reset_fn, self._step_fn = _vector_env(task, make_key(make_kwargs), num_envs, mode)
        self.task, self.env, self.num_envs, self.autoreset_mode = task, env, num_envs, mode
        self.device = device or jax.devices()[0]
        self.array_type = array_type
        self.render_mode = render_mode
        jaxpg_obs_space, self.single_action_space = task_spaces(env)
        gym_space = task in INFO_KEYS and array_type == "numpy"
        self.single_observation_space = (
            gymnasium_observation_space(task, env.observation_size) if gym_space else jaxpg_obs_space
        )
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        fps = max(1, round(1.0 / env.dt))
        self.metadata = {**self.metadata, "render_fps": fps, "autoreset_mode": mode}
        self._state: envs_lib.State | None = None

    def _out(self, x: jax.Array) -> Any:
        return np.array(x) if self.array_type == "numpy" else x

    def _obs_out(self, x: jax.Array) -> Any:
        if self.array_type == "jax":
            return x
        return np.asarray(x, dtype=self.single_observation_space.dtype)

    def _check_open(self) -> None:
        """``RuntimeError`` once ``close`` was called."""
        if self.closed:
            raise RuntimeError(f"this vector env of {self.task} is closed: make a new one")

    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None) -> tuple[Any, dict[str, Any]]:
        """Reset every env. ``seed``: one int ``s`` (env ``i`` is seeded ``s + i``, as in
        Gymnasium's sync and async vector envs, so they all make the same episodes), a list of
        ``num_envs`` ints (one per env), or ``None`` (each env continues its own key stream)."""
        self._check_open()
        super().reset(seed=seed if isinstance(seed, int) or seed is None else None)
        if isinstance(seed, int):
            seed = [seed + i for i in range(self.num_envs)]
        if isinstance(seed, list | tuple):
            if len(seed) != self.num_envs:
                raise ValueError(f"expected {self.num_envs} seeds, got {len(seed)}")
            keys = jnp.stack([seed_key(s) for s in seed])
        elif self._state is not None:
            keys = self._state.info["rng"]
        else:
            start = int(self.np_random.integers(2**31))
            keys = jnp.stack([seed_key(start + i) for i in range(self.num_envs)])
        self._state = self._reset_fn(jax.device_put(keys, self.device))
        info: dict[str, Any] = {}
        if self.task in INFO_KEYS:
            values = jax.device_get(info_arrays(self.task, self._state))
            info = _batched_info(values, INFO_KEYS[self.task][0], np.ones(self.num_envs, bool))
        return self._obs_out(self._state.obs), info

    def step(self, actions: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        self._check_open()
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        if self.array_type == "jax" and isinstance(actions, jax.Array):
            checked = actions  # trusted on the device; shapes are still checked by the env when traced
        else:
            checked = jax.device_put(check_actions(actions, self.single_action_space, self.num_envs), self.device)
        self._state, out = self._step_fn(self._state, checked)
        info = self._info(out) if self.task in INFO_KEYS else {}
        if self.autoreset_mode == AutoresetMode.SAME_STEP:
            info.update(self._finals(out))
        obs, reward, terminated, truncated = (out[k] for k in ("obs", "reward", "terminated", "truncated"))
        reward = reward if self.array_type == "jax" else np.asarray(reward, np.float64)
        return self._obs_out(obs), reward, self._out(terminated), self._out(truncated), info

    def _info(self, out: dict[str, Any]) -> dict[str, Any]:
        """The step's ``info``: every env's reset keys; the step's other keys where a step was
        taken (not in the envs that began an episode here), as Gymnasium's vector envs merge them."""
        reset_keys, step_keys = INFO_KEYS[self.task]
        values, reset = jax.device_get((out["info"], out["reset"]))
        info = _batched_info(values, reset_keys, np.ones(self.num_envs, bool))
        stepped_keys = tuple(k for k in step_keys if k not in reset_keys)
        info.update(_batched_info(values, stepped_keys, ~reset))
        return info

    def _finals(self, out: dict[str, Any]) -> dict[str, Any]:
        """``final_obs`` / ``final_info`` of the envs whose episode ended (same-step mode)."""
        done = np.asarray(out["reset"])
        if not done.any():
            return {}
        final = np.asarray(out["final_obs"], self.single_observation_space.dtype)
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in np.flatnonzero(done):
            final_obs[i] = final[i]
        finals: dict[str, Any] = {"final_obs": final_obs, "_final_obs": done}
        if self.task in INFO_KEYS:
            values = jax.device_get(out["final_info"])
            finals.update(final_info=_batched_info(values, INFO_KEYS[self.task][1], done), _final_info=done)
        return finals

    def render(self) -> np.ndarray | None:
        """A frame of env 0 (``render_mode="rgb_array"``)."""
        if self.render_mode is None or self._state is None:
            return None
        first = jax.tree.map(lambda x: x[0], self._state)
        return render_one(self.env, first)


def make_vector(num_envs: int, task: str, **kwargs: Any) -> JaxpgVectorEnv:
    """``JaxpgVectorEnv`` of ``num_envs`` envs of ``task`` (``kwargs`` go to it and the task);
    the ids' vector entry points (``gymnasium_api``'s ``<Name>VectorEnv``) make the same, in
    the id's fidelity."""
    return JaxpgVectorEnv(task, num_envs, **kwargs)


def gymnasium_vector_env(
    name: str, num_envs: int, device: jax.Device | None = None, **make_kwargs: Any
) -> JaxpgVectorEnv:
    """A ``gymnasium.vector.VectorEnv`` of ``num_envs`` envs of jaxpg task ``name`` (or its
    Gymnasium id) on ``device`` (default: JAX's first); ``make_kwargs`` go to ``JaxpgVectorEnv``
    (``render_mode``, ``array_type``, ``autoreset_mode``) and to the task (``fidelity``,
    ``impl``, ``max_episode_steps`` ...). A task name gets the task's defaults
    (``fidelity="fast"``), a jaxpg id the id's (its fidelity and time limit), as
    ``gymnasium.make_vec(id, num_envs)`` does."""
    of_id = gymnasium_registration.id_arguments(name)
    if of_id is not None:
        limit = gymnasium.spec(name).max_episode_steps
        name, id_kwargs = of_id
        make_kwargs = {**id_kwargs, "max_episode_steps": limit, **make_kwargs}
    if name not in envs_lib.names():
        raise ValueError(f"unknown environment {name!r}; known environments: {', '.join(envs_lib.names())}")
    return JaxpgVectorEnv(name, num_envs, device=device, **make_kwargs)
