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
import os
import re
import subprocess
import sys
from collections.abc import Callable
from typing import Any

import gymnasium
import numpy as np

MIN_GYMNASIUM = (1, 1)


def check_gymnasium_version(version: str) -> None:
    """Raise ``ImportError`` with one line naming the Gymnasium version needed when ``version``
    (e.g. ``gymnasium.__version__``) is older than ``MIN_GYMNASIUM``."""
    match = re.match(r"(\d+)\.(\d+)", version)
    found = (int(match.group(1)), int(match.group(2))) if match else (0, 0)
    if found < MIN_GYMNASIUM:
        need = ".".join(map(str, MIN_GYMNASIUM))
        raise ImportError(
            f"jaxpg's Gymnasium API needs gymnasium>={need}, found {version}: pip install -U 'gymnasium>={need}'"
        )


check_gymnasium_version(getattr(gymnasium, "__version__", "0"))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
from gymnasium import spaces  # noqa: E402
from gymnasium.vector import AutoresetMode  # noqa: E402
from gymnasium.vector.utils import batch_space  # noqa: E402

from jaxpg import envs as envs_lib  # noqa: E402

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

# Tasks with no physics fidelity to choose (pure JAX, the same equations as Gymnasium's).
NO_FIDELITY = frozenset({"cartpole"})

_POSITION = ("x_position", "z_distance_from_origin")
_PLANAR = ("x_position", "y_position", "distance_from_origin")
_TENDONS = ("tendon_length", "tendon_velocity")

# task -> (keys of ``info`` after ``reset``, keys of ``info`` after ``step``): Gymnasium v5's
INFO_KEYS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "hopper": (_POSITION, (*_POSITION, "x_velocity", "reward_forward", "reward_ctrl", "reward_survive")),
    "walker2d": (_POSITION, (*_POSITION, "x_velocity", "reward_forward", "reward_ctrl", "reward_survive")),
    "half_cheetah": (("x_position",), ("x_position", "x_velocity", "reward_forward", "reward_ctrl")),
    "swimmer": (_PLANAR, (*_PLANAR, "x_velocity", "y_velocity", "reward_forward", "reward_ctrl")),
    "ant": (
        _PLANAR,
        (*_PLANAR, "x_velocity", "y_velocity", "reward_forward", "reward_ctrl", "reward_contact", "reward_survive"),
    ),
    "humanoid": (
        (*_PLANAR, *_TENDONS),
        (*_PLANAR, *_TENDONS, "x_velocity", "y_velocity")
        + ("reward_forward", "reward_ctrl", "reward_contact", "reward_survive"),
    ),
    "inverted_pendulum": ((), ("reward_survive",)),
    "inverted_double_pendulum": ((), ("reward_survive", "distance_penalty", "velocity_penalty")),
    "reacher": ((), ("reward_dist", "reward_ctrl")),
    "pusher": ((), ("reward_dist", "reward_ctrl", "reward_near")),
    "cartpole": ((), ()),
}

# info keys read from the physics state (``mjx.Data`` field) rather than the task's metrics.
DATA_INFO = {"tendon_length": "ten_length", "tendon_velocity": "ten_velocity"}

# The single env's own step limit: none (Gymnasium's ``TimeLimit`` truncates).
NO_LIMIT = 2**31 - 1


def fast_id(gym_id: str) -> str:
    """The id of ``gym_id``'s task in jaxpg's fast physics: ``"jaxpg/Hopper-v5"`` ->
    ``"jaxpg/HopperFast-v5"``."""
    name, version = gym_id.rsplit("-v", 1)
    return f"{name}Fast-v{version}"


def gymnasium_observation_space(task: str, size: int) -> spaces.Box:
    """The observation space of Gymnasium's env of ``task`` (``size`` entries): float64 unbounded
    for the MuJoCo tasks; CartPole's float32 box, bounded at twice its termination thresholds."""
    if task == "cartpole":
        from jaxpg.envs.cartpole import CartPole

        high = np.array([2 * CartPole.x_threshold, np.inf, 2 * CartPole.theta_threshold, np.inf], np.float32)
        return spaces.Box(-high, high, dtype=np.float32)
    return spaces.Box(-np.inf, np.inf, (size,), np.float64)


def task_spaces(env: envs_lib.Env) -> tuple[spaces.Space, spaces.Space]:
    """``(observation_space, action_space)`` of one env of a jaxpg task as jaxpg computes it: a
    float32 ``Box`` of ``[observation_size]`` unbounded, and a float32 ``Box`` of
    ``[action_size]`` in the task's range (``Discrete(action_size)`` for a discrete task)."""
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


def info_arrays(task: str, state: envs_lib.State) -> dict[str, jax.Array]:
    """The values of every ``info`` key of ``task`` (``INFO_KEYS``, reset's and step's) in
    ``state``: the task's metrics, or the physics state's fields for ``DATA_INFO`` keys."""
    reset_keys, step_keys = INFO_KEYS[task]
    keys = dict.fromkeys((*reset_keys, *step_keys))
    return {k: _data_field(state.data, DATA_INFO[k]) if k in DATA_INFO else state.metrics[k] for k in keys}


def _data_field(data: Any, name: str) -> jax.Array:
    """Field ``name`` of an ``mjx.Data``, from its implementation's part where MJX keeps it there."""
    impl = getattr(data, "_impl", None)
    return getattr(impl, name) if hasattr(impl, name) else getattr(data, name)


def _host_info(values: dict[str, Any], keys: tuple[str, ...]) -> dict[str, Any]:
    """``info`` of one env from host ``values``: float64 scalars (as Gymnasium's MuJoCo envs give
    them) or float64 arrays, for ``keys``."""
    out: dict[str, Any] = {}
    for k in keys:
        v = np.asarray(values[k], np.float64)
        out[k] = v[()] if v.ndim == 0 else v
    return out


def _render_one(env: envs_lib.Env, state: envs_lib.State) -> np.ndarray:
    """``[H, W, 3] uint8`` frame of one (unbatched) ``state``."""
    from jaxpg import video

    data = state.data
    qpos = np.asarray(data.qpos)[None] if hasattr(data, "qpos") else None
    qvel = np.asarray(data.qvel)[None] if hasattr(data, "qvel") else None
    return video.render_states(env, np.asarray(state.obs)[None], qpos, qvel)[0]


@functools.lru_cache(maxsize=32)
def _single_env(task: str, make_items: tuple) -> tuple[envs_lib.Env, Callable, Callable]:
    """The env and its jitted ``reset``/``step``, shared by every ``JaxpgEnv`` of the same task and
    arguments (so a second env, e.g. a checker's or an evaluation env, compiles nothing)."""
    env = envs_lib.make_shared(task, **dict(make_items))
    return env, jax.jit(env.reset), jax.jit(env.step)


@functools.lru_cache(maxsize=32)
def _set_state_fn(env: envs_lib.Env) -> Callable:
    """Jitted ``(qpos, qvel) -> mjx.Data`` of ``env``'s MJX task, with derived quantities."""
    task = env.unwrapped
    return jax.jit(lambda qpos, qvel: task.physics_state(qpos, qvel, forward=True))


def _items(make_kwargs: dict[str, Any]) -> tuple:
    """``make_kwargs`` as a hashable, order-independent cache key."""
    return tuple(sorted(make_kwargs.items()))


# ----- JAX and fork: a single env made in a process forked after JAX started runs elsewhere -----

_jax_started_before_fork = False
_forked_after_jax = False


def _jax_started() -> bool:
    """JAX has started a backend (and its threads) in this process."""
    try:
        from jax._src import xla_bridge

        return bool(xla_bridge._backends)
    except (ImportError, AttributeError):  # pragma: no cover - a JAX without the private table
        return True


def _before_fork() -> None:
    """``os.fork`` hook in the parent: note whether JAX is running."""
    global _jax_started_before_fork
    _jax_started_before_fork = _jax_started()


def _after_fork_in_child() -> None:
    """``os.fork`` hook in the child: JAX cannot run here if it ran in the parent (nor in its parents)."""
    global _forked_after_jax
    _forked_after_jax = _forked_after_jax or _jax_started_before_fork


os.register_at_fork(before=_before_fork, after_in_child=_after_fork_in_child)


class _Worker:
    """A ``JaxpgEnv`` in a fresh Python process (no fork: a new interpreter), driven through two
    pipes; ``call(name, *args, **kwargs)`` runs ``env.name(...)`` there and returns its result or
    raises its exception."""

    def __init__(self, env_kwargs: dict[str, Any]):
        from multiprocessing.connection import Connection

        to_worker_r, to_worker_w = os.pipe()
        from_worker_r, from_worker_w = os.pipe()
        code = f"from jaxpg.envs.gymnasium_api import _serve; _serve({to_worker_r}, {from_worker_w})"
        path = os.pathsep.join([p for p in sys.path if p] + [os.environ.get("PYTHONPATH", "")])
        self.process = subprocess.Popen(
            [sys.executable, "-c", code],
            pass_fds=(to_worker_r, from_worker_w),
            env={**os.environ, "PYTHONPATH": path},
        )
        os.close(to_worker_r)
        os.close(from_worker_w)
        self._send = Connection(to_worker_w, readable=False)
        self._recv = Connection(from_worker_r, writable=False)
        self.spaces = self._result(env_kwargs)

    def _result(self, message: Any) -> Any:
        try:
            self._send.send(message)
            ok, value = self._recv.recv()
        except (EOFError, OSError):
            code = self.process.wait(timeout=30)
            raise RuntimeError(f"jaxpg's env worker process exited with code {code} (its error is above)") from None
        if not ok:
            raise value
        return value

    def call(self, name: str, *args: Any, **kwargs: Any) -> Any:
        return self._result((name, args, kwargs))

    def close(self) -> None:
        if self.process.poll() is None:
            try:
                self.call("close")
            except RuntimeError:
                pass
            self.process.wait(timeout=30)
        self._send.close()
        self._recv.close()


def _serve(read_fd: int, write_fd: int) -> None:
    """The loop of a ``_Worker``'s process: make the env, then answer calls until ``close``."""
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
        self._worker: _Worker | None = None
        self._start()

    def _start(self) -> None:
        """Make (or fetch) the compiled env here, or start a worker process after a fork."""
        if _forked_after_jax:
            kwargs = {"task": self.task, "render_mode": self.render_mode, **self._make_kwargs}
            self._worker = _Worker(kwargs)
            self.observation_space, self.action_space, self.metadata = self._worker.spaces
            return
        self.env, self._reset_fn, self._step_fn = _single_env(self.task, _items(self._make_kwargs))
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
        return self._observation(obs), _host_info(info, INFO_KEYS[self.task][0])

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        self._check_open()
        if self._worker is not None:
            return self._worker.call("step", action)
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        action = _check_actions(action, self.action_space, None)
        self._state = s = self._step_fn(self._state, jnp.asarray(action))
        obs, reward, terminated, truncated, info = jax.device_get(
            (s.obs, s.reward, s.terminated, s.truncated, info_arrays(self.task, s))
        )
        info = _host_info(info, INFO_KEYS[self.task][1])
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
        return _render_one(self.env, self._state)

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


# ----- the batched vector env -----


def _select(pick_new: jax.Array, new: envs_lib.State, old: envs_lib.State) -> envs_lib.State:
    """``new`` where the scalar ``pick_new`` (one env, inside ``vmap``) else ``old``."""
    mjx = sys.modules.get("mujoco.mjx")
    if mjx is not None and isinstance(old.data, mjx.Data):
        # MJX's own selection: with MuJoCo Warp the contact buffer is shared by the batch.
        data = old.data.where(pick_new, new.data)
    else:
        data = jax.tree.map(lambda n, o: jnp.where(pick_new, n, o), new.data, old.data)
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
        new = _select(restart, env.reset(state.info["rng"]), stepped)
        out = {"obs": new.obs, "reward": new.reward, "terminated": new.terminated, "truncated": new.truncated}
        return new, {**out, "info": info_arrays(task, new), "reset": restart}
    done = stepped.terminated | stepped.truncated
    new = _select(done, env.reset(stepped.info["rng"]), stepped)
    out = {"obs": new.obs, "reward": stepped.reward, "terminated": stepped.terminated, "truncated": stepped.truncated}
    finals = {"final_obs": stepped.obs, "final_info": info_arrays(task, stepped)}
    return new, {**out, "info": info_arrays(task, new), "reset": done, **finals}


@functools.lru_cache(maxsize=16)
def _vector_env(
    task: str, make_items: tuple, num_envs: int, mode: AutoresetMode
) -> tuple[envs_lib.Env, Callable, Callable]:
    """The env and the jitted batched ``reset``/``step`` of ``JaxpgVectorEnv``, shared likewise."""
    env = envs_lib.make_shared(task, batch=num_envs, **dict(make_items))
    step = jax.jit(jax.vmap(functools.partial(_vector_step, env, task, mode)))
    return env, jax.jit(jax.vmap(env.reset)), step


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
        env, self._reset_fn, self._step_fn = _vector_env(task, _items(make_kwargs), num_envs, mode)
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
            keys = jnp.stack([jax.random.PRNGKey(s) for s in seed])
        elif self._state is not None:
            keys = self._state.info["rng"]
        else:
            start = int(self.np_random.integers(2**31))
            keys = jnp.stack([jax.random.PRNGKey(start + i) for i in range(self.num_envs)])
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
            checked = jax.device_put(_check_actions(actions, self.single_action_space, self.num_envs), self.device)
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
        return _render_one(self.env, first)


def make_vector(num_envs: int, task: str, **kwargs: Any) -> JaxpgVectorEnv:
    """The ids' ``vector_entry_point``: ``gymnasium.make_vec(id, num_envs, **kwargs)`` lands here
    with the id's ``task``, ``fidelity`` and ``max_episode_steps``; ``kwargs`` go to
    ``JaxpgVectorEnv`` (``autoreset_mode``, ``render_mode``, ``array_type``, ``device``) and the
    task."""
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
    if name.startswith("jaxpg/") and name in gymnasium.registry:
        spec = gymnasium.spec(name)
        id_kwargs = {k: v for k, v in spec.kwargs.items() if k != "task"}
        make_kwargs = {**id_kwargs, "max_episode_steps": spec.max_episode_steps, **make_kwargs}
        name = spec.kwargs["task"]
    if name not in envs_lib.names():
        raise ValueError(f"unknown environment {name!r}; known environments: {', '.join(envs_lib.names())}")
    return JaxpgVectorEnv(name, num_envs, device=device, **make_kwargs)


_register()
