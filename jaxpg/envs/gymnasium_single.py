"""jaxpg's single Gymnasium env (``JaxpgEnv``): one task, jitted ``reset`` and ``step``, Gymnasium's
start states, types and ``MujocoEnv`` attributes; ``gymnasium_api`` has the contract and the ids.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Callable
from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from jaxpg import envs as envs_lib
from jaxpg.envs import compile_options, gymnasium_mujoco, gymnasium_worker
from jaxpg.envs.gymnasium_spaces import (  # the version check runs first
    INFO_KEYS,
    NO_LIMIT,
    check_actions,
    enable_compile_cache,
    gymnasium_observation_space,
    host_info,
    host_reward,
    info_arrays,
    make_key,
    render_one,
    seed_key,
    task_spaces,
)


@functools.lru_cache(maxsize=32)
def _single_env(task: str, make_items: tuple) -> tuple[envs_lib.Env, Callable, Callable]:
    """The env and its jitted ``reset``/``step``, shared by every ``JaxpgEnv`` of the same task and
    arguments (so a second env, e.g. a checker's or an evaluation env, compiles nothing)."""
    env = envs_lib.make_shared(task, **dict(make_items))
    return env, compile_options.jit(env.reset, env), compile_options.jit(env.step, env)


@functools.lru_cache(maxsize=32)
def _start_fn(env: envs_lib.Env) -> Callable:
    """Jitted ``(qpos [nq], qvel [nv]) -> State``: the reset of ``env``'s MJX task at that start
    state (``MjxEnv.start_state``), wrappers' bookkeeping included."""
    task = env.unwrapped

    def start(qpos: jax.Array, qvel: jax.Array) -> envs_lib.State:
        state = env.reset(jax.random.PRNGKey(0))  # its draws are unused: XLA drops them
        data, obs, metrics = task.start_state(qpos, qvel)
        return state.replace(data=data, obs=obs.astype(jnp.float32), metrics={**state.metrics, **metrics})

    return compile_options.jit(start, env)


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


# Gymnasium's ``MujocoEnv`` keywords that jaxpg's envs cannot honour: one ``ValueError`` each.
REFUSED_KEYWORDS = {
    "xml_file": "jaxpg simulates its own copy of Gymnasium's model of the task; another model file is not supported",
    "default_camera_config": "jaxpg renders from the model's tracking camera or MuJoCo's default free camera",
    "max_geom": "jaxpg's renderer keeps MuJoCo's default scene size",
    "visual_options": "jaxpg's renderer keeps MuJoCo's default visual options",
}
# The attributes of Gymnasium's ``MujocoEnv`` that ``JaxpgEnv`` gives for an MJX task.
MUJOCO_ATTRIBUTES = ("data", "model", "dt", "frame_skip", "init_qpos", "init_qvel", "state_vector")


def check_keywords(task: str, keywords: dict[str, Any]) -> None:
    """``ValueError`` naming the first of Gymnasium's ``MujocoEnv`` keywords in ``keywords`` that
    jaxpg cannot honour (``REFUSED_KEYWORDS``; ``frame_skip`` and the render keywords are checked by
    ``JaxpgEnv``)."""
    for name, why in REFUSED_KEYWORDS.items():
        if name in keywords:
            raise ValueError(f"{name}={keywords[name]!r} is not supported by jaxpg's {task} env: {why}")


class JaxpgEnv(gymnasium.Env):
    """One jaxpg task as a ``gymnasium.Env`` (``gymnasium_api``'s docstring); jitted ``reset`` and ``step``.

    Make it through ``gymnasium.make("jaxpg/...")`` (or ``gymnasium_env``), which adds
    Gymnasium's ``TimeLimit``; the bare class never truncates. ``make_kwargs`` go to the task
    (``fidelity``, ``impl``, reward weights ...). Gymnasium's ``MujocoEnv`` keywords: ``width``,
    ``height``, ``camera_id``, ``camera_name`` set the rendering; ``frame_skip`` is accepted at
    the task's own value; the others are refused by name (``REFUSED_KEYWORDS``).

    For an MJX task the env has ``MujocoEnv``'s attributes (``MUJOCO_ATTRIBUTES``): ``data`` (a
    MuJoCo ``MjData`` set to the env's state whenever it is read; writing to it changes nothing:
    use ``set_state``), ``model`` (the ``MjModel`` MJX simulates, this env's copy: changing it
    changes nothing either), ``dt``, ``frame_skip``, ``init_qpos``, ``init_qvel`` (float64) and
    ``state_vector()``. In Gymnasium's physics ``reset`` draws Gymnasium's start state from
    ``np_random`` (``gymnasium_mujoco.draw_start``).
    """

    metadata = {"render_modes": ["rgb_array", "depth_array"], "render_fps": 50}

    def __init__(
        self,
        task: str,
        render_mode: str | None = None,
        width: int = 480,
        height: int = 480,
        camera_id: int | None = None,
        camera_name: str | None = None,
        frame_skip: int | None = None,
        **make_kwargs: Any,
    ):
        if render_mode not in (None, "rgb_array", "depth_array"):
            raise ValueError(f"render_mode must be None, 'rgb_array' or 'depth_array', got {render_mode!r}")
        if task not in INFO_KEYS:
            raise ValueError(f"no Gymnasium env for task {task!r}; tasks with one: {', '.join(INFO_KEYS)}")
        check_keywords(task, make_kwargs)
        for name, size in (("width", width), ("height", height)):
            if not isinstance(size, int) or size < 1:
                raise ValueError(f"{name} must be a positive integer, got {size!r}")
        self.task = task
        self.render_mode = render_mode
        self._view = {"width": width, "height": height, "camera_id": camera_id, "camera_name": camera_name}
        self._frame_skip = frame_skip
        self._make_kwargs = {"max_episode_steps": NO_LIMIT, **make_kwargs}
        self._state: envs_lib.State | None = None
        self._closed = False
        self._worker: gymnasium_worker.Worker | None = None
        self._start()

    def _start(self) -> None:
        """Make (or fetch) the compiled env here, or start a worker process after a fork."""
        if gymnasium_worker.forked_after_jax():
            kwargs = {"task": self.task, "render_mode": self.render_mode, **self._view, **self._make_kwargs}
            if self._frame_skip is not None:
                kwargs["frame_skip"] = self._frame_skip
            self._worker = gymnasium_worker.Worker(kwargs)
            self.observation_space, self.action_space, self.metadata = self._worker.spaces
            return
        enable_compile_cache()
        self.env, self._reset_fn, self._step_fn = _single_env(self.task, make_key(self._make_kwargs))
        task = self.env.unwrapped
        self._mujoco = hasattr(task, "start_state")
        if self._mujoco:
            if self._frame_skip not in (None, task.frame_skip):
                raise ValueError(
                    f"frame_skip={self._frame_skip!r} is not supported by jaxpg's {self.task} env: "
                    f"it steps the physics {task.frame_skip} times per env step (Gymnasium's default)"
                )
            self._model = copy.copy(task.mj_model)
            self._mj_data = mujoco.MjData(self._model)
            self._data_of: envs_lib.State | None = None  # the state ``_mj_data`` holds
            self._renderer: Any = None
        elif self._frame_skip is not None or self.render_mode == "depth_array":
            what = "frame_skip" if self._frame_skip is not None else "render_mode='depth_array'"
            raise ValueError(f"{what} is for MuJoCo tasks; {self.task} is not one")
        self._gymnasium_starts = self._mujoco and task.fidelity == "gymnasium"
        _, self.action_space = task_spaces(self.env)
        self.observation_space = gymnasium_observation_space(self.task, self.env.observation_size)
        self.metadata = {**type(self).metadata, "render_fps": max(1, round(1.0 / self.env.dt))}

    def _check_open(self) -> None:
        """``RuntimeError`` once ``close`` was called."""
        if self._closed:
            raise RuntimeError(f"this {self.task} env is closed: make a new one")

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        """Start an episode. In Gymnasium's physics (an MJX task), the start state is drawn from
        ``np_random`` as Gymnasium's env of the task draws it, so the same seed starts the same
        episode; otherwise from JAX's random numbers (keyed by ``seed``, or continuing the env's
        key stream)."""
        self._check_open()
        if self._worker is not None:
            return self._worker.call("reset", seed=seed, options=options)
        super().reset(seed=seed)
        if self._gymnasium_starts:
            qpos, qvel = gymnasium_mujoco.draw_start(self.task, self.env.unwrapped, self.np_random)
            self._state = _start_fn(self.env)(qpos, qvel)
            gymnasium_mujoco.set_start(self._model, self._mj_data, qpos, qvel)
            self._data_of = self._state
            keys = INFO_KEYS[self.task][0]
            info = gymnasium_mujoco.reset_info(self.task, keys, self._mj_data, self.init_qpos)
            return self._observation(jax.device_get(self._state.obs)), info
        if seed is not None:
            key = seed_key(seed)
        elif self._state is not None:
            key = self._state.info["rng"]  # the episode's key for the next reset, as in the vector env
        else:
            key = seed_key(int(self.np_random.integers(2**31)))
        self._state = self._reset_fn(key)
        obs, info = jax.device_get((self._state.obs, info_arrays(self.task, self._state)))
        return self._observation(obs), host_info(info, INFO_KEYS[self.task][0], self.task)

    def step(self, action: Any) -> tuple[np.ndarray, Any, bool, bool, dict]:
        """One step; the reward and ``info`` values typed as Gymnasium's env of the task types them
        (``gymnasium_spaces.REWARD_TYPES``, ``INFO_TYPES``)."""
        self._check_open()
        if self._worker is not None:
            return self._worker.call("step", action)
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        dtype = np.asarray(action).dtype
        action = check_actions(action, self.action_space, None)
        self._state = s = self._step_fn(self._state, jnp.asarray(action))
        obs, reward, terminated, truncated, info = jax.device_get(
            (s.obs, s.reward, s.terminated, s.truncated, info_arrays(self.task, s))
        )
        info = host_info(info, INFO_KEYS[self.task][1], self.task, dtype)
        return self._observation(obs), host_reward(self.task, reward), bool(terminated), bool(truncated), info

    def _observation(self, obs: np.ndarray) -> np.ndarray:
        return np.asarray(obs, dtype=self.observation_space.dtype)

    def set_state(self, qpos: Any, qvel: Any) -> None:
        """Set an MJX task's joint positions ``qpos [nq]`` and velocities ``qvel [nv]``, as
        Gymnasium's ``MujocoEnv.set_state`` does (the next ``step`` starts from them)."""
        self._check_open()
        if self._worker is not None:
            return self._worker.call("set_state", qpos, qvel)
        task = self.env.unwrapped
        if not self._mujoco or self._state is None:
            raise RuntimeError(f"set_state needs a MuJoCo task after reset(); {self.task} is not one or was not reset")
        qpos, qvel = np.asarray(qpos, np.float64), np.asarray(qvel, np.float64)
        if qpos.shape != (task.nq,) or qvel.shape != (task.nv,):
            raise ValueError(
                f"expected qpos of shape ({task.nq},) and qvel ({task.nv},), got {qpos.shape} {qvel.shape}"
            )
        start = _start_fn(self.env)(qpos, qvel)
        self._state = self._state.replace(data=start.data, obs=start.obs)
        gymnasium_mujoco.set_start(self._model, self._mj_data, qpos, qvel)
        self._data_of = self._state
        return None

    # ----- Gymnasium's MujocoEnv attributes (MJX tasks) -----

    def _mujoco_task(self, name: str) -> Any:
        """The MJX task, or ``AttributeError`` naming ``name`` for a task with no MuJoCo model."""
        if not self._mujoco:
            raise AttributeError(f"{name!r}: jaxpg's {self.task} env is not a MuJoCo env")
        return self.env.unwrapped

    def _remote(self, name: str) -> Any:
        return self._worker.call("__getattribute__", name)

    @property
    def model(self) -> mujoco.MjModel:
        """The MuJoCo model MJX simulates (this env's copy; changing it does not change the physics)."""
        if self._worker is not None:
            return self._remote("model")
        self._mujoco_task("model")
        return self._model

    @property
    def data(self) -> mujoco.MjData:
        """A MuJoCo ``MjData`` at the env's current state (positions, velocities, controls, time,
        after ``mj_forward``), refreshed whenever the state changed since it was last read."""
        if self._worker is not None:
            return self._remote("data")
        self._mujoco_task("data")
        if self._state is not None and self._data_of is not self._state:
            physics = self._state.data
            fields = {"time": physics.time} | {n: _field(physics, n) for n in gymnasium_mujoco.STATE_FIELDS}
            gymnasium_mujoco.put_state(self._model, self._mj_data, jax.device_get(fields))
            self._data_of = self._state
        return self._mj_data

    @property
    def dt(self) -> float:
        """Simulated seconds per step: the model's timestep times ``frame_skip``."""
        if self._worker is not None:
            return self._remote("dt")
        return self.env.dt

    @property
    def frame_skip(self) -> int:
        """Physics steps per env step."""
        if self._worker is not None:
            return self._remote("frame_skip")
        return self._mujoco_task("frame_skip").frame_skip

    @property
    def init_qpos(self) -> np.ndarray:
        """``[nq]`` float64: the model's reference positions, which resets add noise to."""
        if self._worker is not None:
            return self._remote("init_qpos")
        return np.array(self._mujoco_task("init_qpos").mj_model.qpos0, np.float64)

    @property
    def init_qvel(self) -> np.ndarray:
        """``[nv]`` float64 zeros, which resets add noise to."""
        if self._worker is not None:
            return self._remote("init_qvel")
        return np.zeros(self._mujoco_task("init_qvel").nv, np.float64)

    def state_vector(self) -> np.ndarray:
        """``[nq + nv]`` float64: the current positions then velocities, as ``MujocoEnv.state_vector``."""
        if self._worker is not None:
            return self._worker.call("state_vector")
        return np.concatenate([self.data.qpos.flat, self.data.qvel.flat])

    def render(self) -> np.ndarray | None:
        """A frame of the current state: ``[H, W, 3] uint8`` (``"rgb_array"``) or ``[H, W]``
        float32 depths in metres (``"depth_array"``; MJX tasks), ``width`` x ``height``."""
        self._check_open()
        if self._worker is not None:
            return self._worker.call("render")
        if self.render_mode is None or self._state is None:
            return None
        if not self._mujoco:
            return render_one(self.env, self._state)
        if self._renderer is None:
            self._renderer = self._make_renderer()
        frame_of = self._view["camera_name"] if self._view["camera_name"] is not None else self._view["camera_id"]
        return gymnasium_mujoco.render(
            self._renderer, self._model, self.data, self.render_mode == "depth_array", frame_of
        )

    def _make_renderer(self) -> Any:
        """A MuJoCo renderer of ``width`` x ``height`` (the model's offscreen buffer grown to fit,
        as Gymnasium grows it), or ``video.RenderError`` naming what is missing."""
        from jaxpg import video

        problem = video.gl_problem()
        if problem is not None:
            raise video.RenderError(f"MuJoCo cannot render here: {problem}")
        width, height = self._view["width"], self._view["height"]
        visual = self._model.vis.global_
        visual.offwidth, visual.offheight = max(visual.offwidth, width), max(visual.offheight, height)
        return mujoco.Renderer(self._model, height=height, width=width)

    def close(self) -> None:
        """Release the env; ``reset`` and ``step`` raise ``RuntimeError`` afterwards."""
        if self._worker is not None:
            self._worker.close()
            self._worker = None
        if getattr(self, "_renderer", None) is not None:
            self._renderer.close()
            self._renderer = None
        self._closed = True
        super().close()

    def __getstate__(self) -> dict[str, Any]:
        """Everything but the compiled functions and MuJoCo's objects, with the episode's state as
        NumPy arrays."""
        if self._worker is not None:
            raise TypeError("a JaxpgEnv running in a worker process (made after a fork) cannot be pickled")
        skip = ("env", "_reset_fn", "_step_fn", "_worker", "_model", "_mj_data", "_data_of", "_renderer")
        state = {k: v for k, v in self.__dict__.items() if k not in skip}
        state["_state"] = jax.device_get(self._state)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._worker = None
        if not self._closed:
            self._start()


def _field(physics: Any, name: str) -> jax.Array:
    """Field ``name`` of an ``mjx.Data``, from its implementation's part where MJX keeps it there."""
    impl = getattr(physics, "_impl", None)
    return getattr(physics, name) if hasattr(physics, name) else getattr(impl, name)
