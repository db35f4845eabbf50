"""Tests of the env API's guards and of the one-line messages for missing optional extras.

Action checks: ``env.step`` rejects an action of the wrong shape (or a float action for a discrete
task) when it is traced, under ``jit`` and ``vmap`` too; shape errors are found with
``jax.eval_shape``, which traces without compiling. Discrete actions out of range end the episode
and are counted in ``metrics["invalid_action"]``. Missing extras: Gymnasium for
``jaxpg.evaluate --gymnasium``, warp-lang for ``impl="warp"``, an OpenGL library for rendering
(``jaxpg.video``; this machine has OSMesa, so its absence is simulated by replacing the library
lookup).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import script_loader

import jaxpg.envs as envs
from jaxpg import video
from jaxpg.envs import tasks
from jaxpg.envs.base import check_action
from jaxpg.envs.cartpole import CartPole
from jaxpg.run.evaluation import evaluate_cli, replay

ROOT = Path(__file__).parent.parent


class ToyCartPole(CartPole):
    """A task that only this test declares: the cart-pole's equations under a name of its own."""


def test_a_task_declared_in_one_place_resolves_by_name():
    """One ``envs.register`` call (``jaxpg.envs.tasks``) makes a task: ``make`` builds it by name,
    its Gymnasium counterpart and ``info`` keys are known, and it is gone once unregistered."""
    envs.register("toy_cartpole", envs.Task(f"{__name__}:ToyCartPole", "CartPole-v1", 500))
    try:
        assert "toy_cartpole" in envs.names()
        assert type(envs.make("toy_cartpole").unwrapped) is ToyCartPole
        assert replay.gymnasium_counterpart("toy_cartpole") == "CartPole-v1"
        assert envs.GYMNASIUM_COUNTERPARTS["toy_cartpole"] == ("CartPole-v1", 500)
        assert tasks.INFO_KEYS["toy_cartpole"] == ((), ())
    finally:
        envs.unregister("toy_cartpole")
    assert "toy_cartpole" not in envs.names() and "toy_cartpole" not in tasks.INFO_KEYS
    with pytest.raises(ValueError, match="unknown environment 'toy_cartpole'"):
        envs.make("toy_cartpole")


def test_the_task_table_is_read_without_importing_a_task():
    """``jaxpg.envs`` knows every task's name and Gymnasium id before importing any task module
    (MuJoCo and MJX stay unimported)."""
    code = (
        "import sys, jaxpg.envs as e; "
        "print(len(e.names()), e.GYMNASIUM_COUNTERPARTS['hopper'], "
        "[m for m in ('mujoco', 'jaxpg.envs.hopper', 'jaxpg.envs.mjx_env') if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == [str(len(tasks.TASKS)), "('Hopper-v5',", "1000)", "[]"]


@pytest.fixture(scope="module")
def hopper():
    """The bare Hopper (3 actuators) and its wrapped stack; only traced here, never compiled."""
    task = envs.make_task("hopper", impl="jax")
    return task, envs.EpisodeStats(envs.ClipAction(task))


def abstract_state(env: envs.Env, batch: int | None = None) -> envs.State:
    """The ``State`` pytree of shapes of one env (or of ``batch`` envs), without running anything."""
    if batch is None:
        return jax.eval_shape(env.reset, jax.random.key(0))
    return jax.eval_shape(jax.vmap(env.reset), jax.random.split(jax.random.key(0), batch))


# --------------------------------------------------------------------------------------------
# 1. action shapes, checked at trace time


@pytest.mark.parametrize("shape", [(2,), (), (4,), (1,), (8, 3)])
@pytest.mark.parametrize("wrapped", [False, True], ids=["bare", "wrapped"])
def test_continuous_action_of_wrong_shape_raises(hopper, shape, wrapped):
    """Hopper wants ``[3]``: ``[2]``, a scalar (which ``ClipAction`` or the actuators would
    broadcast), ``[4]``, ``[1]`` and a batch all raise ``ValueError`` naming both shapes, through
    the wrappers too, under ``jit``."""
    env = hopper[1] if wrapped else hopper[0]
    state = abstract_state(env)
    action = jax.ShapeDtypeStruct(shape, jnp.float32)
    with pytest.raises(ValueError, match=rf"hopper expects an action of shape \(3,\), got {_re(shape)}"):
        jax.eval_shape(jax.jit(env.step), state, action)


def test_action_shape_message_is_exact(hopper):
    with pytest.raises(ValueError) as err:
        check_action(hopper[1], jnp.zeros(2))
    assert str(err.value) == "hopper expects an action of shape (3,), got (2,)"
    with pytest.raises(ValueError, match=r"got \(8, 3\) \(step acts on one environment: use jax.vmap"):
        check_action(hopper[1], jnp.zeros((8, 3)))


def test_vmap_checks_the_action_of_one_env(hopper):
    """Under ``vmap`` the check sees each env's action: ``[N, 3]`` passes the check, ``[N, 2]`` and
    ``[N]`` (a scalar per env) fail with the per-env shape in the message."""
    task = hopper[0]
    states = abstract_state(task, batch=4)
    step = jax.vmap(check_action, in_axes=(None, 0))
    assert jax.eval_shape(lambda a: step(task, a), jax.ShapeDtypeStruct((4, 3), jnp.float32)).shape == (4, 3)
    for shape, given in [((4, 2), r"\(2,\)"), ((4,), r"\(\)")]:
        with pytest.raises(ValueError, match=rf"expects an action of shape \(3,\), got {given}(\s|$)"):
            jax.eval_shape(jax.vmap(task.step), states, jax.ShapeDtypeStruct(shape, jnp.float32))


def test_continuous_valid_action_passes():
    """The pendulum's ``[1]`` action traces through the whole stack, batched and not."""
    env = envs.make("inverted_pendulum", impl="jax")
    out = jax.eval_shape(env.step, abstract_state(env), jax.ShapeDtypeStruct((1,), jnp.float32))
    assert out.obs.shape == (env.observation_size,)
    assert out.metrics["invalid_action"].shape == ()
    with pytest.raises(ValueError, match=r"inverted_pendulum expects an action of shape \(1,\), got \(\)"):
        jax.eval_shape(env.step, abstract_state(env), jax.ShapeDtypeStruct((), jnp.float32))


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.bool_])
def test_discrete_non_integer_action_raises(dtype):
    env = envs.make("cartpole")
    with pytest.raises(ValueError, match=r"cartpole expects an integer action of shape \(\).*got dtype"):
        jax.eval_shape(jax.jit(env.step), abstract_state(env), jax.ShapeDtypeStruct((), dtype))
    with pytest.raises(ValueError, match=r"got dtype float32"):  # a Python float too
        env.step(env.reset(jax.random.key(0)), 1.0)


@pytest.mark.parametrize("shape", [(1,), (2,), (4, 1)])
def test_discrete_non_scalar_action_raises(shape):
    env = envs.make("cartpole")
    with pytest.raises(ValueError, match=rf"cartpole expects an integer action of shape \(\).*got shape {_re(shape)}"):
        jax.eval_shape(env.step, abstract_state(env), jax.ShapeDtypeStruct(shape, jnp.int32))
    batched = abstract_state(env, batch=4)
    with pytest.raises(ValueError, match=r"got shape \(2,\)"):
        jax.eval_shape(jax.vmap(env.step), batched, jax.ShapeDtypeStruct((4, 2), jnp.int32))


# --------------------------------------------------------------------------------------------
# 2. discrete actions out of range: the step is not taken, the episode ends, it is counted


def test_cartpole_out_of_range_action_is_counted_and_ends_the_episode():
    """Actions 7 and -1 neither push left nor right: the cart-pole keeps its state, the step is
    ``terminated`` with reward 0 and a zeroed observation, ``invalid_action`` is 1 (0 for 0 and 1),
    and ``AutoReset`` starts a new episode. One compiled batched step covers all four."""
    env = envs.AutoReset(envs.make("cartpole"))
    actions = jnp.asarray([0, 1, 7, -1], jnp.int32)
    states = jax.vmap(env.reset)(jax.random.split(jax.random.key(0), 4))
    out = jax.jit(jax.vmap(env.step))(states, actions)
    np.testing.assert_array_equal(out.metrics["invalid_action"], [0.0, 0.0, 1.0, 1.0])
    np.testing.assert_array_equal(out.metrics["nonfinite"], 0.0)
    np.testing.assert_array_equal(out.terminated, [False, False, True, True])
    np.testing.assert_array_equal(out.reward, [1.0, 1.0, 0.0, 0.0])
    np.testing.assert_array_equal(out.info["final_obs"][2:], 0.0)
    np.testing.assert_array_equal(out.metrics["episode_done"], [0.0, 0.0, 1.0, 1.0])
    pushed = out.data.state[:2, 1] - states.data.state[:2, 1]  # cart velocity: left, then right
    assert pushed[0] < 0 < pushed[1]
    assert not np.any(np.asarray(out.obs[2:]) == 0.0)  # a fresh episode after the reset

    task = envs.make_task("cartpole")
    state = task.reset(jax.random.key(1))
    for bad in (7, -1):
        after = task.step(state, jnp.asarray(bad))
        np.testing.assert_array_equal(after.data.state, state.data.state)  # not advanced
        assert float(after.metrics["invalid_action"]) == 1.0 and bool(after.terminated)


def test_pong_out_of_range_action_does_not_move_the_paddle():
    task = envs.make_task("pong", size=16)
    state = task.reset(jax.random.key(0))
    after = task.step(state, jnp.asarray(5))
    np.testing.assert_array_equal(after.data.paddles, state.data.paddles)
    np.testing.assert_array_equal(after.data.ball, state.data.ball)
    assert float(after.metrics["invalid_action"]) == 1.0 and bool(after.terminated) and float(after.reward) == 0.0
    assert float(task.step(state, jnp.asarray(1)).metrics["invalid_action"]) == 0.0


def test_continuous_nan_action_is_nonfinite():
    """A NaN passes ``ClipAction`` as NaN (never clipped to a bound) and ends the episode as
    ``nonfinite``; ``invalid_action`` stays for discrete tasks."""
    env = envs.make("inverted_pendulum", impl="jax")
    out = jax.jit(env.step)(env.reset(jax.random.key(0)), jnp.asarray([jnp.nan]))
    assert float(out.metrics["nonfinite"]) == 1.0 and float(out.metrics["invalid_action"]) == 0.0
    assert bool(out.terminated) and float(out.reward) == 0.0
    np.testing.assert_array_equal(out.obs, 0.0)


def test_every_task_reports_invalid_action_from_reset():
    """``invalid_action`` is one of the metrics of every task, from ``reset`` on (same keys always)."""
    for name in ("cartpole", "inverted_pendulum"):
        env = envs.make(name) if name == "cartpole" else envs.make(name, impl="jax")
        assert "invalid_action" in abstract_state(env).metrics


# --------------------------------------------------------------------------------------------
# 3. missing optional extras: one line naming the install command


def test_evaluate_gymnasium_without_gymnasium(monkeypatch, tmp_path, capsys):
    """``python -m jaxpg.evaluate RUN --gymnasium`` without Gymnasium: one line, exit 2."""
    monkeypatch.setitem(sys.modules, "gymnasium", None)  # `import gymnasium` raises ImportError
    assert evaluate_cli.main([str(tmp_path), "--gymnasium"]) == 2
    err = capsys.readouterr().err
    assert err == "error: --gymnasium needs Gymnasium: pip install 'gymnasium[mujoco]'\n"
    with pytest.raises(ImportError, match=r"pip install 'gymnasium\[mujoco\]'"):
        replay.gymnasium_reference_env("cartpole", {})


def test_evaluate_gymnasium_without_gymnasium_in_a_subprocess(tmp_path):
    """The same from the command line, with ``import gymnasium`` failing in a fresh interpreter."""
    script = tmp_path / "no_gymnasium.py"
    script.write_text(
        "import runpy, sys\nsys.modules['gymnasium'] = None\nrunpy.run_module('jaxpg.evaluate', run_name='__main__')\n"
    )
    proc = subprocess.run(
        [sys.executable, str(script), str(tmp_path), "--gymnasium"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": script_loader.python_path()},
        timeout=300,
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == "error: --gymnasium needs Gymnasium: pip install 'gymnasium[mujoco]'\n"


def test_evaluate_video_checks_gl_only_for_mujoco_tasks(hopper, monkeypatch):
    """``evaluate --video`` asks for an OpenGL backend before playing, and only for tasks drawn
    by MuJoCo: CartPole (drawn with NumPy) needs none, in jaxpg's env or in Gymnasium."""
    monkeypatch.setattr(video, "gl_problem", lambda: "no OpenGL here: apt-get install libosmesa6, MUJOCO_GL=osmesa")

    def fake_run(task: str, env: envs.Env):
        return type("Run", (), {"task": task, "make_env": lambda self: env})()

    assert "apt-get install libosmesa6" in evaluate_cli._video_problem(fake_run("hopper", hopper[1]), gymnasium=False)
    assert "apt-get install libosmesa6" in evaluate_cli._video_problem(fake_run("hopper", hopper[1]), gymnasium=True)
    cartpole = envs.make("cartpole")
    assert evaluate_cli._video_problem(fake_run("cartpole", cartpole), gymnasium=False) is None
    assert evaluate_cli._video_problem(fake_run("cartpole", cartpole), gymnasium=True) is None


def test_warp_without_warp_lang(monkeypatch):
    from jaxpg.envs import mjx_env, mjx_import

    monkeypatch.setattr(mjx_env, "warp_available", lambda: False)
    monkeypatch.setattr(mjx_import, "warp_installed", lambda: False)
    with pytest.raises(ValueError, match=r"^impl='warp' needs the warp-lang package: pip install 'jaxpg\[warp\]'$"):
        envs.make_task("hopper", impl="warp")


# --------------------------------------------------------------------------------------------
# 4. GL backends: set only when their library loads; rendering without one says what to install


def _finder(*present: str):
    """A ``find_library`` that finds the libraries named in ``present`` and no other. Each is
    "found" as the C library, which loads on any Linux machine: the tests check how the backend is
    chosen, not which GL packages this machine has (without libosmesa6 they failed)."""
    import ctypes.util

    libc = ctypes.util.find_library("c")
    return lambda name: libc if name in present else None


def test_choose_gl_backend_only_picks_installed_libraries():
    assert video.choose_gl_backend(nvidia=False, find=_finder("OSMesa", "EGL", "OpenGL")) == "osmesa"
    assert video.choose_gl_backend(nvidia=True, find=_finder("OSMesa", "EGL", "OpenGL")) == "egl"
    assert video.choose_gl_backend(nvidia=True, find=_finder("OSMesa", "EGL")) == "osmesa"  # no libOpenGL/libGL
    assert video.choose_gl_backend(nvidia=True, find=_finder()) is None
    assert video.choose_gl_backend(nvidia=False, find=_finder("EGL", "OpenGL")) is None
    assert not video.gl_library_found("osmesa", find=lambda name: "libdoes-not-exist.so.1")  # found, not loadable


def test_gl_problem_is_one_line_naming_the_package():
    none_found = _finder()
    for backend, display in [("osmesa", None), ("egl", None), ("", None), ("glfw", None)]:
        problem = video.gl_problem(backend, display or "", find=none_found)
        assert problem is not None and "\n" not in problem
        assert "apt-get install libosmesa6" in problem and "MUJOCO_GL" in problem
    assert video.gl_problem("osmesa", "", find=_finder("OSMesa")) is None
    assert video.gl_problem("", ":0", find=none_found) is None  # GLFW with a display may work


def test_without_osmesa_mujoco_imports_and_rendering_fails_in_one_line(tmp_path):
    """A fresh interpreter where no GL library can be found: ``configure_gl`` leaves ``MUJOCO_GL``
    unset, ``import mujoco`` works, and ``render_mujoco`` raises ``RenderError`` in one line."""
    script = tmp_path / "no_gl.py"
    script.write_text(
        textwrap.dedent(
            """
            import ctypes.util, json, os, sys
            ctypes.util.find_library = lambda name: None  # no libOSMesa, no libEGL
            from jaxpg import video
            backend = video.configure_gl()
            import mujoco
            model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='0.1'/></worldbody></mujoco>")
            try:
                video.render_mujoco(model, [model.qpos0], [[]] , width=32, height=32)
                message = None
            except video.RenderError as e:
                message = str(e)
            print(json.dumps({"backend": backend, "env": os.environ.get("MUJOCO_GL"), "message": message}))
            """
        )
    )
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY", "PYOPENGL_PLATFORM")}
    proc = subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        env={**env, "PYTHONPATH": script_loader.python_path()},
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["backend"] is None and out["env"] is None
    message = out["message"]
    assert message is not None and "\n" not in message
    assert "apt-get install libosmesa6" in message and "MUJOCO_GL" in message
    assert proc.stderr == ""


def test_notebook_rendering_cell_degrades_to_one_line(capsys):
    """Notebook 01 lets ``configure_gl`` choose the backend (no unconditional ``MUJOCO_GL=osmesa``)
    and the rendering part of its video cell prints one line when rendering is impossible."""
    nb = json.loads((ROOT / "notebooks" / "01_npg_hopper.ipynb").read_text())
    code = ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]
    assert not any('"MUJOCO_GL", "osmesa"' in src for src in code)
    assert "video.configure_gl()" in code[0]
    cell = next(src for src in code if "render_mujoco" in src)
    rendering = cell[cell.index("try:") :]  # the part after the MJX rollout: render, encode, display

    class FakeTask:
        mj_model, dt = None, 0.008

    class FakeEnv:
        unwrapped = FakeTask()

    def no_gl(*args, **kwargs):
        raise video.RenderError("MuJoCo cannot render here: no OpenGL backend (apt-get install libosmesa6)")

    def unreachable(*args, **kwargs):
        raise AssertionError("nothing is encoded or displayed without frames")

    fake_video = type("V", (), {"render_mujoco": staticmethod(no_gl), "RenderError": video.RenderError})
    namespace = {
        "env": FakeEnv(),
        "qpos": np.zeros((16, 7)),
        "qvel": np.zeros((16, 6)),
        "STRIDE": 8,
        "small_gif": unreachable,
        "display": unreachable,
        "Image": unreachable,
        "video": fake_video,
    }
    exec(compile(rendering, "cell", "exec"), namespace)  # noqa: S102
    printed = capsys.readouterr().out
    assert printed.count("\n") == 1 and "apt-get install libosmesa6" in printed
    assert namespace["frames"] == []


def _re(shape: tuple[int, ...]) -> str:
    """A shape as a regular expression: ``(2,)`` -> ``\\(2,\\)``."""
    return str(tuple(shape)).replace("(", r"\(").replace(")", r"\)")


def test_make_sizes_the_physics_for_the_batch():
    """``envs.make(name, batch=N)`` is all a caller says about batch size: MuJoCo Warp's shared
    contact buffer is sized for it (at least the default 8192), other backends ignore it."""
    assert envs.warp_capacity("hopper", {"impl": "warp"}, 20000) == {"max_batch": 20000}
    assert envs.warp_capacity("hopper", {"impl": "warp"}, 64) == {"max_batch": 8192}
    assert envs.warp_capacity("hopper", {"impl": "jax"}, 20000) == {}
    assert envs.warp_capacity("cartpole", {}, 20000) == {}
    assert envs.make("cartpole", batch=5).unwrapped.name == "cartpole"
    with pytest.raises(ValueError, match="batch must be a positive integer"):
        envs.make("cartpole", batch=0)


def test_gl_problem_names_the_backend_in_effect():
    none_found = lambda name: None  # noqa: E731
    assert "MUJOCO_GL unset" in video.gl_problem("", "", find=none_found)
    assert "MUJOCO_GL=glfw" in video.gl_problem("glfw", "", find=none_found)


def test_make_shared_returns_one_env_per_task_and_arguments():
    """``envs.make_shared`` makes each (task, arguments) once, so jitted programs keyed on the env
    object are reused; other arguments give another env."""
    first = envs.make_shared("cartpole")
    assert envs.make_shared("cartpole") is first
    assert envs.make_shared("cartpole", max_episode_steps=100) is not first
    assert envs.make_shared("cartpole", max_episode_steps=100).max_episode_steps == 100
