"""The host side of jaxpg's single Gymnasium env of an MJX task: Gymnasium's start states (the
draws of its ``MujocoEnv.reset_model`` from the env's ``np_random``), the ``info`` of a reset in
float64 as Gymnasium computes it, a MuJoCo ``MjData`` kept in step with the env's MJX state, and
rendering (``gymnasium_api`` has the env).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

Draw = Callable[[Any, np.random.Generator], tuple[np.ndarray, np.ndarray]]


def _init(task: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(init_qpos [nq], init_qvel [nv])`` float64, as Gymnasium's ``MujocoEnv`` keeps them."""
    return np.array(task.mj_model.qpos0, np.float64), np.zeros(task.mj_model.nv, np.float64)


def _uniform_uniform(task: Any, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Uniform noise of +-``reset_noise_scale`` on qpos, then on qvel (Hopper, Walker2d, Swimmer,
    Humanoid, HumanoidStandup, InvertedPendulum)."""
    init_qpos, init_qvel = _init(task)
    s = task.reset_noise_scale
    qpos = init_qpos + rng.uniform(low=-s, high=s, size=task.nq)
    qvel = init_qvel + rng.uniform(low=-s, high=s, size=task.nv)
    return qpos, qvel


def _uniform_normal(task: Any, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Uniform noise of +-``reset_noise_scale`` on qpos, then a normal of that scale on qvel
    (HalfCheetah, Ant, InvertedDoublePendulum)."""
    init_qpos, init_qvel = _init(task)
    s = task.reset_noise_scale
    qpos = init_qpos + rng.uniform(low=-s, high=s, size=task.nq)
    qvel = init_qvel + s * rng.standard_normal(task.nv)
    return qpos, qvel


def _reacher(task: Any, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Reacher: noise on all of qpos, then targets drawn in the square until one falls inside the
    disk (it replaces qpos's last two), then noise on qvel with the target's velocity zeroed."""
    init_qpos, init_qvel = _init(task)
    s, v, r = task.arm_noise_scale, task.arm_velocity_noise_scale, task.target_radius
    qpos = rng.uniform(low=-s, high=s, size=task.nq) + init_qpos
    while True:
        goal = rng.uniform(low=-r, high=r, size=2)
        if np.linalg.norm(goal) < r:
            break
    qpos[-2:] = goal
    qvel = init_qvel + rng.uniform(low=-v, high=v, size=task.nv)
    qvel[-2:] = 0
    return qpos, qvel


def _pusher(task: Any, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Pusher: the object's position drawn (two draws of one number each) until more than 0.17
    from the goal at the origin, then noise on the arm's qvel."""
    init_qpos, init_qvel = _init(task)
    goal = np.zeros(2)
    while True:
        cylinder = np.concatenate([rng.uniform(low=-0.3, high=0, size=1), rng.uniform(low=-0.2, high=0.2, size=1)])
        if np.linalg.norm(cylinder - goal) > 0.17:
            break
    qpos = init_qpos.copy()
    qpos[-4:-2] = cylinder
    qpos[-2:] = goal
    qvel = init_qvel + rng.uniform(low=-0.005, high=0.005, size=task.nv)
    qvel[-4:] = 0
    return qpos, qvel


# task -> how Gymnasium's ``reset_model`` of its env draws the start state (the same calls on the
# same generator, in the same order; read from Gymnasium's v5 envs).
START_DRAWS: dict[str, Draw] = {
    "hopper": _uniform_uniform,
    "walker2d": _uniform_uniform,
    "swimmer": _uniform_uniform,
    "humanoid": _uniform_uniform,
    "humanoid_standup": _uniform_uniform,
    "inverted_pendulum": _uniform_uniform,
    "half_cheetah": _uniform_normal,
    "ant": _uniform_normal,
    "inverted_double_pendulum": _uniform_normal,
    "reacher": _reacher,
    "pusher": _pusher,
}


def draw_start(name: str, task: Any, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Gymnasium's start state ``(qpos [nq], qvel [nv])`` float64 of task ``name`` drawn from
    ``rng`` (the env's ``np_random``), with the task's noise scales."""
    return START_DRAWS[name](task, rng)


# index of the height in qpos for ``z_distance_from_origin``
_HEIGHT = {"hopper": 1, "walker2d": 1, "humanoid_standup": 2}


def reset_info(name: str, keys: tuple[str, ...], data: mujoco.MjData, init_qpos: np.ndarray) -> dict[str, Any]:
    """``info`` of a reset (``keys``) from the MuJoCo ``data`` of the start state, computed as
    Gymnasium's ``_get_reset_info`` does (float64, the same operations: equal to the bit)."""
    values = {
        "x_position": lambda: data.qpos[0],
        "y_position": lambda: data.qpos[1],
        "distance_from_origin": lambda: np.linalg.norm(data.qpos[0:2], ord=2),
        "z_distance_from_origin": lambda: data.qpos[_HEIGHT[name]] - init_qpos[_HEIGHT[name]],
        "tendon_length": lambda: data.ten_length.copy(),
        "tendon_velocity": lambda: data.ten_velocity.copy(),
    }
    return {k: values[k]() for k in keys}


# the fields of an ``mjx.Data`` besides ``time`` that hold MuJoCo's state as jaxpg's tasks change
# it, copied into a host ``MjData`` before its forward pass
STATE_FIELDS = ("qpos", "qvel", "act", "ctrl", "qacc_warmstart")


def put_state(model: mujoco.MjModel, data: mujoco.MjData, physics: dict[str, Any]) -> None:
    """Set MuJoCo ``data`` to the MJX state ``physics`` (host values of an ``mjx.Data``'s ``time``
    and ``STATE_FIELDS``), then run ``mj_forward`` so that its derived quantities (``xpos``,
    ``ten_length`` ...) describe that state."""
    mujoco.mj_resetData(model, data)
    data.time = float(physics["time"])
    for name in STATE_FIELDS:
        value = np.asarray(physics[name])
        if value.size:
            getattr(data, name)[:] = value
    mujoco.mj_forward(model, data)


def set_start(model: mujoco.MjModel, data: mujoco.MjData, qpos: np.ndarray, qvel: np.ndarray) -> None:
    """``data`` at a start state, as Gymnasium's reset sets it (``mj_resetData``, ``qpos``,
    ``qvel``, ``mj_forward``)."""
    mujoco.mj_resetData(model, data)
    data.qpos[:] = qpos
    data.qvel[:] = qvel
    mujoco.mj_forward(model, data)


def camera(model: mujoco.MjModel, chosen: int | str | None = None) -> Any:
    """The camera of ``chosen`` (an id or a name) if given, else the model's ``track`` camera if it
    has one, else MuJoCo's default free camera."""
    if chosen is not None:
        return chosen
    for name in ("track", "tracking"):
        cam_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        if cam_id >= 0:
            return cam_id
    free = mujoco.MjvCamera()
    mujoco.mjv_defaultFreeCamera(model, free)
    return free


def render(
    renderer: mujoco.Renderer, model: mujoco.MjModel, data: mujoco.MjData, depth: bool, chosen: int | str | None
) -> np.ndarray:
    """A frame of ``data`` from camera ``chosen`` (``camera``): ``[H, W, 3] uint8`` colours, or
    ``[H, W] float32`` depths in metres (``depth``), as Gymnasium's ``rgb_array`` and
    ``depth_array`` give them."""
    if depth:
        renderer.enable_depth_rendering()
    else:
        renderer.disable_depth_rendering()
    renderer.update_scene(data, camera=camera(model, chosen))
    return renderer.render().copy()
