"""Videos of policy rollouts: MuJoCo's offscreen renderer for MJX tasks, a drawn frame for CartPole.

MJX states live on the accelerator; a frame is rendered by copying ``qpos``/``qvel`` into a CPU
``mujoco.MjData``, running ``mj_forward`` and ``mujoco.Renderer``. MuJoCo picks its OpenGL
backend when it is first imported, from ``MUJOCO_GL``: ``configure_gl`` sets it, before that
import, to ``egl`` on an NVIDIA GPU machine and to ``osmesa`` (software; Debian/Ubuntu package
``libosmesa6``) otherwise, but only to a backend whose shared libraries are installed: with
``MUJOCO_GL=osmesa`` and no libOSMesa, ``import mujoco`` itself fails. Without any, it leaves
``MUJOCO_GL`` unset, MuJoCo imports and simulates as usual, and rendering raises ``RenderError``
with one line naming the package to install (``gl_problem``). Pure-JAX tasks without MuJoCo
(CartPole) are drawn with NumPy from the observation, or by the env's own
``render_frame(obs) -> [H, W, 3] uint8`` when it (the task or a wrapper that changes the
observation, e.g. Pong's ``FrameDifference``) has one.

Files are mp4 (H.264 through imageio-ffmpeg) or gif, chosen by the extension.
"""

from __future__ import annotations

import ctypes.util
import math
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

WIDTH, HEIGHT = 480, 480
MAX_FPS = 60


class RenderError(RuntimeError):
    """Rendering is not possible here (no GL backend, or a task that cannot be drawn)."""


# Shared libraries that PyOpenGL loads for each offscreen backend: one name of each group must load.
GL_LIBRARIES: dict[str, tuple[tuple[str, ...], ...]] = {
    "osmesa": (("OSMesa",),),
    "egl": (("EGL",), ("OpenGL", "GL")),
}
RENDER_HINT = (
    "install OSMesa (apt-get install libosmesa6) and set MUJOCO_GL=osmesa, "
    "or set MUJOCO_GL=egl on an NVIDIA GPU machine (libEGL)"
)

LibraryFinder = Callable[[str], str | None]


def _find_library(name: str) -> str | None:
    """``ctypes.util.find_library``, looked up at call time (tests replace it)."""
    return ctypes.util.find_library(name)


def _loadable(path: str | None) -> bool:
    """The shared library ``path`` (a name ``find_library`` returned) can be loaded."""
    if not path:
        return False
    try:
        ctypes.CDLL(path)
    except OSError:
        return False
    return True


def gl_library_found(backend: str, find: LibraryFinder = _find_library) -> bool:
    """The libraries of the offscreen ``backend`` (``"osmesa"`` or ``"egl"``) can be found and
    loaded; other backends (GLFW, GLX) are not checked and count as found."""
    groups = GL_LIBRARIES.get(backend.lower())
    if groups is None:
        return True
    return all(any(_loadable(find(name)) for name in group) for group in groups)


def choose_gl_backend(nvidia: bool, find: LibraryFinder = _find_library) -> str | None:
    """``"egl"`` on an NVIDIA machine with EGL installed, else ``"osmesa"`` where OSMesa is
    installed, else ``None`` (leave ``MUJOCO_GL`` alone)."""
    if nvidia and gl_library_found("egl", find):
        return "egl"
    if gl_library_found("osmesa", find):
        return "osmesa"
    return None


def _has_nvidia() -> bool:
    return os.path.exists("/proc/driver/nvidia") or os.path.exists("/dev/nvidia0")


def configure_gl() -> str | None:
    """Choose MuJoCo's offscreen GL backend (``MUJOCO_GL``) unless it is set or too late.

    Must run before ``mujoco`` is first imported. Sets only a backend whose libraries load
    (``choose_gl_backend``); with none, ``MUJOCO_GL`` stays unset so that ``import mujoco`` works,
    and rendering later raises ``RenderError`` saying what to install. Returns the backend in
    effect (``None``: MuJoCo will use GLFW, which needs a display).
    """
    if "MUJOCO_GL" in os.environ or not sys.platform.startswith("linux"):
        return os.environ.get("MUJOCO_GL")
    if "mujoco" in sys.modules:
        return None
    backend = choose_gl_backend(_has_nvidia())
    if backend is not None:
        os.environ["MUJOCO_GL"] = backend
    return backend


def gl_problem(
    backend: str | None = None, display: str | None = None, find: LibraryFinder = _find_library
) -> str | None:
    """One line saying why MuJoCo cannot render offscreen here, or ``None`` when it may.

    ``backend`` and ``display`` default to ``MUJOCO_GL`` and ``DISPLAY`` from the environment.
    Only Linux is checked: a missing library of ``MUJOCO_GL=osmesa``/``egl``, or GLFW (no
    ``MUJOCO_GL``) without a display.
    """
    if not sys.platform.startswith("linux"):
        return None
    backend = (os.environ.get("MUJOCO_GL", "") if backend is None else backend).lower().strip()
    display = os.environ.get("DISPLAY") if display is None else display
    if backend in GL_LIBRARIES:
        if gl_library_found(backend, find):
            return None
        return f"MUJOCO_GL={backend} but its OpenGL library is not installed: {RENDER_HINT}"
    if backend in ("", "glfw", "glx", "enable", "enabled", "on", "true", "1") and not display:
        setting = f"MUJOCO_GL={backend}" if backend else "MUJOCO_GL unset"
        return f"no OpenGL backend for offscreen rendering ({setting}, no display): {RENDER_HINT}"
    return None


def _render_hint() -> str:
    backend = os.environ.get("MUJOCO_GL")
    if backend == "osmesa" or not backend:
        return RENDER_HINT
    return f"MUJOCO_GL={backend} did not work; try MUJOCO_GL=osmesa (apt-get install libosmesa6)"


def _first_line(e: BaseException) -> str:
    """``"Type: first line of the message"``."""
    lines = str(e).strip().splitlines()
    return f"{type(e).__name__}: {lines[0]}" if lines else type(e).__name__


# --------------------------------------------------------------------------- frames


def _camera(model: Any) -> Any:
    """The model's ``track`` camera if it has one, else MuJoCo's default free camera."""
    import mujoco

    for name in ("track", "tracking"):
        cam_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        if cam_id >= 0:
            return cam_id
    camera = mujoco.MjvCamera()
    mujoco.mjv_defaultFreeCamera(model, camera)
    return camera


def render_mujoco(
    mj_model: Any, qpos: np.ndarray, qvel: np.ndarray, width: int = WIDTH, height: int = HEIGHT
) -> list[np.ndarray]:
    """Frames ``[H, W, 3] uint8`` of the states ``qpos [T, nq]``, ``qvel [T, nv]``.

    Raises ``RenderError`` (a one-line message naming what to install) without an OpenGL backend.
    """
    import mujoco

    width = min(width, int(mj_model.vis.global_.offwidth))
    height = min(height, int(mj_model.vis.global_.offheight))
    problem = gl_problem()
    if problem is not None:
        raise RenderError(f"MuJoCo cannot render here: {problem}")
    try:
        with warnings.catch_warnings():  # GLFW warns once per failed call; the error says it all
            warnings.simplefilter("ignore")
            renderer = mujoco.Renderer(mj_model, height=height, width=width)
    except Exception as e:  # noqa: BLE001 - every GL failure means the same to the user
        raise RenderError(f"MuJoCo cannot render here ({_first_line(e)}); {_render_hint()}") from None
    data = mujoco.MjData(mj_model)
    camera = _camera(mj_model)
    frames = []
    try:
        for q, v in zip(np.asarray(qpos), np.asarray(qvel), strict=True):
            data.qpos[:] = q
            data.qvel[:] = v
            mujoco.mj_forward(mj_model, data)
            renderer.update_scene(data, camera=camera)
            frames.append(renderer.render().copy())
    finally:
        renderer.close()
    return frames


def draw_cartpole(obs: np.ndarray, width: int = 640, height: int = 400) -> np.ndarray:
    """A CartPole frame ``[H, W, 3] uint8`` from Gymnasium's observation ``[x, x_dot, theta,
    theta_dot]`` (track +-2.4, pole half-length 0.5, as Gymnasium's ``CartPole-v1``)."""
    x, theta = float(obs[0]), float(obs[2])
    world_width = 4.8
    scale = width / world_width
    frame = np.full((height, width, 3), 255, np.uint8)
    track_y = int(height * 0.7)
    frame[track_y : track_y + 2, :] = 0
    cart_x = int(width / 2 + x * scale)
    cart_w, cart_h = 50, 30
    x0, x1 = max(cart_x - cart_w // 2, 0), min(cart_x + cart_w // 2, width)
    y0, y1 = track_y - cart_h // 2, track_y + cart_h // 2
    if x0 < x1:
        frame[y0:y1, x0:x1] = 0
    pole_len = scale * 1.0
    axle_y = y0 + 4
    ts = np.linspace(0.0, 1.0, int(pole_len) * 2)
    px = cart_x + ts * pole_len * math.sin(theta)
    py = axle_y - ts * pole_len * math.cos(theta)
    half = 5
    for dx in range(-half, half + 1):
        cols = np.round(px + dx * math.cos(theta)).astype(int)
        rows = np.round(py + dx * math.sin(theta)).astype(int)
        ok = (cols >= 0) & (cols < width) & (rows >= 0) & (rows < height)
        frame[rows[ok], cols[ok]] = (202, 152, 101)
    ay, ax_ = np.ogrid[:height, :width]
    axle = (ay - axle_y) ** 2 + (ax_ - cart_x) ** 2 <= 25
    frame[axle] = (129, 132, 203)
    return frame


def _is_cartpole(task: Any) -> bool:
    return type(task).__name__.lower() == "cartpole"


def render_states(env: Any, obs: np.ndarray, qpos: np.ndarray | None, qvel: np.ndarray | None) -> list[np.ndarray]:
    """Frames of one episode's states (``obs [T, obs_dim]``, and ``qpos``/``qvel`` for MJX tasks)."""
    task = env.unwrapped
    if hasattr(env, "render_frame"):  # wrappers forward it: the outermost layer that draws its obs
        return [np.asarray(env.render_frame(o)) for o in obs]
    if hasattr(task, "mj_model") and qpos is not None:
        return render_mujoco(task.mj_model, qpos, qvel)
    if _is_cartpole(task):
        return [draw_cartpole(o) for o in obs]
    raise RenderError(f"task {type(task).__name__} has no renderer (neither a MuJoCo model nor render_frame)")


# --------------------------------------------------------------------------- files


def frame_stride(dt: float, max_fps: int = MAX_FPS) -> tuple[int, float]:
    """``(stride, fps)``: keep every ``stride``-th frame so that real time plays at <= max_fps."""
    fps = 1.0 / dt
    stride = max(1, round(fps / max_fps))
    return stride, fps / stride


def write_video(frames: Sequence[np.ndarray], path: str | os.PathLike, fps: float) -> Path:
    """Write ``frames`` to ``path``: ``.mp4`` (H.264) or ``.gif``."""
    path = Path(path)
    if not frames:
        raise RenderError("no frames to write")
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix.lower()
    with warnings.catch_warnings():
        # JAX warns about fork() in a threaded process; ffmpeg is exec-ed at once: harmless.
        warnings.simplefilter("ignore", RuntimeWarning)
        _write(frames, path, fps, suffix)
    return path


def _write(frames: Sequence[np.ndarray], path: Path, fps: float, suffix: str) -> None:
    import imageio.v2 as imageio

    if suffix == ".gif":
        imageio.mimsave(path, list(frames), duration=1000.0 / fps, loop=0)
    elif suffix in (".mp4", ".m4v", ".mov", ".mkv", ".webm"):
        writer = imageio.get_writer(
            path,
            fps=fps,
            codec="libx264" if suffix != ".webm" else None,
            quality=7,
            macro_block_size=16,
            ffmpeg_log_level="error",
        )
        try:
            for frame in frames:
                writer.append_data(frame)
        finally:
            writer.close()
    else:
        raise RenderError(f"unsupported video format {suffix!r}: use .mp4 or .gif")


def save_episode_video(
    env: Any, obs: np.ndarray, qpos: np.ndarray | None, qvel: np.ndarray | None, path: str | os.PathLike
) -> Path:
    """Render one episode's states and write them to ``path`` at the env's real-time speed."""
    stride, fps = frame_stride(float(env.dt))
    sl = slice(None, None, stride)
    frames = render_states(env, obs[sl], None if qpos is None else qpos[sl], None if qvel is None else qvel[sl])
    return write_video(frames, path, fps)
