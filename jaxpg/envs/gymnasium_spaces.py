"""What jaxpg's Gymnasium envs share: their ids, Gymnasium's spaces and ``info`` keys for each task,
action checks, host-side conversions to Gymnasium's types, the compile cache (``gymnasium_api``
has the contract and the ids' entry points, ``gymnasium_single`` the single env,
``gymnasium_vector`` the batched vector env, ``gymnasium_registration`` the ids' registration).

Importing it checks Gymnasium's version first: an older Gymnasium gets one ``ImportError`` line
naming the version needed.
"""

from __future__ import annotations

import functools
import re
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
from gymnasium import spaces  # noqa: E402

from jaxpg import envs as envs_lib  # noqa: E402
from jaxpg.envs.gymnasium_registration import NO_FIDELITY, fast_id  # noqa: E402, F401 - part of this module's API
from jaxpg.envs.tasks import INFO_KEYS  # noqa: E402 - task -> Gymnasium's info keys after reset and step

# jaxpg's Gymnasium id -> (jaxpg task, Gymnasium's step limit for it): ``jaxpg/<id>`` for each of
# ``envs.GYMNASIUM_COUNTERPARTS``.
GYMNASIUM_IDS: dict[str, tuple[str, int]] = {
    f"jaxpg/{gym_id}": (task, limit) for task, (gym_id, limit) in envs_lib.GYMNASIUM_COUNTERPARTS.items()
}


# info keys read from the physics state (``mjx.Data`` field) rather than the task's metrics.
DATA_INFO = {"tendon_length": "ten_length", "tendon_velocity": "ten_velocity"}

# The single env's own step limit: none (Gymnasium's ``TimeLimit`` truncates).
NO_LIMIT = 2**31 - 1


@functools.cache
def enable_compile_cache() -> Any:
    """Turn on jaxpg's persistent compilation cache in this process, once, before a Gymnasium env
    compiles (``jaxpg.run.host.compile_cache.enable_unless_chosen``: a second process making the same
    env loads its programs; ``JAXPG_COMPILATION_CACHE=off`` leaves the cache off)."""
    from jaxpg.run.host import compile_cache

    return compile_cache.enable_unless_chosen()


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


def check_actions(actions: Any, space: spaces.Space, batch: int | None) -> np.ndarray:
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


# The Python types of the rewards and ``info`` values of Gymnasium's envs where they are not
# NumPy float64 scalars (arrays are float64): what ``gymnasium.utils.env_checker.data_equivalence``
# compares first. ``ACTION_TYPED`` keys take the action's float type (float32 for the actions its
# spaces sample), as Gymnasium computes them from the action.
REWARD_TYPES: dict[str, type] = {"inverted_pendulum": int, "cartpole": float}
INFO_TYPES: dict[str, dict[str, type]] = {
    "hopper": {"reward_survive": float},
    "inverted_pendulum": {"reward_survive": int},
    "inverted_double_pendulum": {"reward_survive": float},
}
ACTION_TYPED: dict[str, frozenset[str]] = {
    task: frozenset({"reward_ctrl"})
    for task in ("hopper", "walker2d", "half_cheetah", "ant", "swimmer", "reacher", "pusher")
}


def host_reward(task: str, reward: Any) -> Any:
    """The reward of one step as Gymnasium's env of ``task`` types it (``REWARD_TYPES``, else a
    NumPy float64)."""
    kind = REWARD_TYPES.get(task, np.float64)
    return kind(round(float(reward))) if kind is int else kind(reward)


def host_info(
    values: dict[str, Any], keys: tuple[str, ...], task: str | None = None, action_dtype: Any = np.float32
) -> dict[str, Any]:
    """``info`` of one env from host ``values`` for ``keys``: each scalar of the type Gymnasium's
    env of ``task`` gives it (``INFO_TYPES``, ``ACTION_TYPED`` with ``action_dtype``, else NumPy
    float64), arrays float64."""
    types = INFO_TYPES.get(task, {})
    action_typed = ACTION_TYPED.get(task, frozenset())
    out: dict[str, Any] = {}
    for k in keys:
        v = np.asarray(values[k], np.float64)
        if v.ndim:
            out[k] = v
        elif k in action_typed:
            out[k] = np.result_type(action_dtype, np.float32).type(v)
        else:
            kind = types.get(k, np.float64)
            out[k] = kind(round(float(v))) if kind is int else kind(v)
    return out


def render_one(env: envs_lib.Env, state: envs_lib.State) -> np.ndarray:
    """``[H, W, 3] uint8`` frame of one (unbatched) ``state``."""
    from jaxpg import video

    data = state.data
    qpos = np.asarray(data.qpos)[None] if hasattr(data, "qpos") else None
    qvel = np.asarray(data.qvel)[None] if hasattr(data, "qvel") else None
    return video.render_states(env, np.asarray(state.obs)[None], qpos, qvel)[0]


def make_key(make_kwargs: dict[str, Any]) -> tuple:
    """``make_kwargs`` as a hashable, order-independent cache key."""
    return tuple(sorted(make_kwargs.items()))


def seed_key(seed: int) -> jax.Array:
    """A JAX PRNG key of ``seed``, any non-negative integer (Gymnasium accepts seeds past 64 bits,
    and JAX's 32-bit ``PRNGKey`` keeps only a seed's low 32 bits): ``PRNGKey`` of the low 32 bits,
    each higher 32 bits folded in, so that every seed below 2**32 keeps its ``PRNGKey(seed)``."""
    key = jax.random.PRNGKey(seed % 2**32)
    high = seed >> 32
    while high:
        key = jax.random.fold_in(key, high % 2**32)
        high >>= 32
    return key
