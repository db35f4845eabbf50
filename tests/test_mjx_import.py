"""MJX imported without MuJoCo Warp where a command will not use it (``jaxpg.envs.mjx_import``,
``jaxpg.run.command.startup.steps_mjx_on_jax_only``). Which modules a process imported is process state, so
the checks that import MJX run in fresh interpreters."""

import os
import re
import subprocess
import sys

import pytest

from jaxpg.envs import mjx_import
from jaxpg.run.command import startup
from jaxpg.run.command.command_line import Experiment
from jaxpg.run.command.pre_flags import PreFlags


def test_the_variable_says_off_in_the_usual_ways():
    assert mjx_import.warp_left_out({"JAXPG_MJX_WARP": "off"})
    assert mjx_import.warp_left_out({"JAXPG_MJX_WARP": " OFF "})
    assert mjx_import.warp_left_out({"JAXPG_MJX_WARP": "0"})
    assert not mjx_import.warp_left_out({"JAXPG_MJX_WARP": "on"})
    assert not mjx_import.warp_left_out({})


def test_a_command_leaves_warp_out_only_when_it_will_step_mjx_on_jax():
    fresh, experiment = PreFlags(), Experiment()
    assert startup.steps_mjx_on_jax_only(fresh, experiment, "cpu")  # the default on a CPU is jax
    assert not startup.steps_mjx_on_jax_only(fresh, experiment, "gpu")  # and warp on a GPU
    assert startup.steps_mjx_on_jax_only(PreFlags(impl="jax"), experiment, "gpu")
    assert not startup.steps_mjx_on_jax_only(PreFlags(impl="warp"), experiment, "cpu")
    assert not startup.steps_mjx_on_jax_only(fresh, Experiment(env_kwargs={"impl": "warp"}), "cpu")
    assert startup.steps_mjx_on_jax_only(fresh, Experiment(env_kwargs={"impl": "jax"}), "gpu")


def test_a_resumed_run_leaves_warp_out_when_its_saved_impl_steps_on_jax(tmp_path):
    """``--resume RUN`` without ``--impl``: the ``impl`` RUN's ``config.json`` saved decides; a
    directory whose configuration cannot be read keeps Warp (planning reports it)."""
    from jaxpg.run.rundir import config_io

    def saved(name: str, impl: str | None) -> PreFlags:
        run_dir = tmp_path / name
        run_dir.mkdir()
        env_kwargs = {} if impl is None else {"impl": impl}
        config_io.RunConfig(task="hopper", algo="npg", config={}, seeds=[0], iterations=1, env_kwargs=env_kwargs).save(
            run_dir
        )
        return PreFlags(resume=str(run_dir))

    experiment = Experiment()
    assert startup.steps_mjx_on_jax_only(saved("none", None), experiment, "cpu")
    assert not startup.steps_mjx_on_jax_only(saved("none_gpu", None), experiment, "gpu")
    assert startup.steps_mjx_on_jax_only(saved("jax", "jax"), experiment, "gpu")
    assert not startup.steps_mjx_on_jax_only(saved("warp", "warp"), experiment, "cpu")
    assert startup.steps_mjx_on_jax_only(PreFlags(resume=saved("warp2", "warp").resume, impl="jax"), experiment, "cpu")
    assert not startup.steps_mjx_on_jax_only(PreFlags(resume=str(tmp_path / "missing")), experiment, "cpu")
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "config.json").write_text("{not json")
    assert not startup.steps_mjx_on_jax_only(PreFlags(resume=str(tmp_path / "broken")), experiment, "cpu")


def python(code: str, **environ: str) -> str:
    """``code`` run by a fresh interpreter of this environment (plus ``environ``): its stdout."""
    env = {k: v for k, v in os.environ.items() if k != mjx_import.WARP_VARIABLE} | environ
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


LEFT_OUT = """
import sys
from jaxpg import envs
from jaxpg.envs import mjx_env, mjx_import
warp_modules = ("warp.", "mujoco.mjx.third_party.mujoco_warp._src.")  # the package stubs above them load
loaded = sorted(m for m in sys.modules if m == "warp" or m.startswith(warp_modules))
print("loaded:", loaded, "available:", mjx_env.warp_available())
env = envs.make_task("hopper", impl="jax")  # MJX's JAX implementation is there
print("jax:", env.impl, env.nq)
try:
    envs.make_task("hopper", impl="warp")
except ValueError as e:
    print("warp:", e)
if mjx_import.warp_installed():
    import warp  # only MJX's import was spared it
    print("import warp: ok")
"""


def test_mjx_without_warp_steps_on_jax_and_says_why_warp_is_missing():
    out = python(LEFT_OUT, JAXPG_MJX_WARP="off")
    assert "loaded: [] available: False" in out
    assert "jax: jax 6" in out
    if mjx_import.warp_installed():
        assert "warp: impl='warp': this process imported MJX without MuJoCo Warp (JAXPG_MJX_WARP=off)" in out
        assert "import warp: ok" in out
    else:
        assert "needs the warp-lang package" in out


@pytest.mark.skipif(not mjx_import.warp_installed(), reason="warp-lang is not installed (pip install 'jaxpg[warp]')")
def test_the_command_line_imports_warp_only_when_asked_for_it():
    """A command that stops with a usage error right after importing MJX (a bad task option),
    under ``python -X importtime``: on a CPU MuJoCo Warp's modules are not imported, unless the
    command asks for ``--impl warp``."""

    def warp_modules(*flags: str) -> int:
        argv = [sys.executable, "-X", "importtime", "-m", "jaxpg.cli", "--env", "hopper", *flags]
        env = {k: v for k, v in os.environ.items() if k != mjx_import.WARP_VARIABLE} | {"JAX_PLATFORMS": "cpu"}
        proc = subprocess.run([*argv, "--env-kwargs", "bogus=1"], capture_output=True, text=True, env=env)
        assert proc.returncode == 2 and "has no option 'bogus'" in proc.stderr, proc.stderr[-2000:]
        assert re.search(r"\| +mujoco\.mjx\n", proc.stderr)  # MJX itself was imported
        return proc.stderr.count("mujoco.mjx.third_party.mujoco_warp._src.")

    assert warp_modules() <= 1  # the first of them, started and abandoned: "import warp" failed
    assert warp_modules("--impl", "warp") > 20


def test_runs_jax_only_follows_the_default_implementation():
    assert mjx_import.runs_jax_only(None, "cpu") and mjx_import.runs_jax_only("jax", "gpu")
    assert not mjx_import.runs_jax_only(None, "gpu") and not mjx_import.runs_jax_only("warp", "cpu")


@pytest.mark.skipif(not mjx_import.warp_installed(), reason="warp-lang is not installed (pip install 'jaxpg[warp]')")
def test_evaluating_a_run_on_the_cpu_leaves_warp_out(tmp_path):
    """``python -m jaxpg.evaluate RUN --gymnasium`` of an inverted-pendulum run (an untrained
    policy's checkpoint: nothing is trained) imports MJX without MuJoCo Warp's modules on a CPU."""
    import jax

    from jaxpg import algos
    from jaxpg.run.checkpoints.checkpointer import Checkpointer
    from jaxpg.run.rundir import config_io, layout

    module = algos.get("npg")
    config = module.Config(num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), value_batch_size=8)
    run = config_io.RunConfig(
        task="inverted_pendulum", algo="npg", config=config_io.config_to_dict(config), seeds=[0], iterations=1
    )
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    run.save(run_dir)
    state = module.init(jax.random.PRNGKey(0), run.make_env(), config)
    Checkpointer(run_dir / layout.CHECKPOINT_DIR, keep=None, create=True).save(
        1, state, score=0.0, info={"task": run.task, "algo": run.algo, "seeds": [0]}
    )
    argv = [sys.executable, "-X", "importtime", "-m", "jaxpg.evaluate", str(run_dir), "--gymnasium", "--episodes", "1"]
    env = {k: v for k, v in os.environ.items() if k != mjx_import.WARP_VARIABLE} | {"JAX_PLATFORMS": "cpu"}
    proc = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0 and "Gymnasium InvertedPendulum-v5" in proc.stdout, proc.stderr[-2000:]
    assert re.search(r"\| +mujoco\.mjx\n", proc.stderr)  # MJX was imported, for the run's env
    assert proc.stderr.count("mujoco.mjx.third_party.mujoco_warp._src.") <= 1


MESH_MODEL = """
import hashlib, sys
{first}
import jax, mujoco, numpy as np
from jaxpg import envs
from jaxpg.envs import mjx_import
mjx, _ = mjx_import.import_mjx()
envs.make_task("hopper", impl="jax")
print("after hopper:", type(sys.modules.get("trimesh")).__name__, type(sys.modules.get("scipy.spatial")).__name__)
xml = '''<mujoco><asset><mesh name="box" vertex="0 0 0 1 0 0 0 1 0 1 1 0 0 0 1 1 0 1 0 1 1 1 1 1"/></asset>
<worldbody><geom type="plane" size="5 5 .1"/><body><freejoint/><geom type="mesh" mesh="box"/></body></worldbody>
</mujoco>'''
model = mjx.put_model(mujoco.MjModel.from_xml_string(xml), impl="jax")  # MJX takes the mesh's convex hull
arrays = [np.asarray(x) for x in jax.tree.leaves(model) if hasattr(x, "shape")]
print("model:", hashlib.sha256(b"".join(x.tobytes() for x in arrays)).hexdigest())
import trimesh
import scipy.spatial
print("after mesh:", type(trimesh).__name__, trimesh.Trimesh.__module__, type(scipy.spatial).__name__)
"""


def test_mjx_imports_trimesh_and_scipy_spatial_only_for_a_model_with_meshes():
    """MJX is imported with trimesh and scipy.spatial deferred: building a task (no meshes) leaves
    them unimported; a model with a mesh imports them and gets the same MJX model as a process that
    imported both before MJX; ``import trimesh`` and ``import scipy.spatial`` then give the modules
    themselves."""
    deferred = python(MESH_MODEL.format(first=""), JAXPG_MJX_WARP="off")
    imported_first = python(MESH_MODEL.format(first="import trimesh, scipy.spatial"), JAXPG_MJX_WARP="off")
    assert "after hopper: NoneType NoneType" in deferred and "after hopper: module module" in imported_first
    digest = [line for line in deferred.splitlines() if line.startswith("model:")]
    assert digest and digest[0] in imported_first.splitlines()
    assert "after mesh: module trimesh.base module" in deferred
