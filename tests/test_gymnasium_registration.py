"""How a process gets jaxpg's Gymnasium ids and its compile cache: the start-up hook that registers
the ids in a script that never imports jaxpg (Gymnasium 1.x reads no plugin entry points), its
command line, and the persistent compilation cache that every process making a jaxpg env turns on.
Each check runs in a fresh Python process."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from jaxpg import envs
from jaxpg.envs import gymnasium_registration

REPO = Path(__file__).resolve().parents[1]


def run_python(code: str, env: dict[str, str] | None = None, timeout: int = 600) -> subprocess.CompletedProcess:
    """``code`` in a fresh interpreter with this checkout first on the path."""
    path = os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])
    environ = {**os.environ, **(env or {}), "PYTHONPATH": path}
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=timeout, env=environ
    )


def test_the_registration_table_is_jaxpgs():
    """The ids' table that registers without importing jaxpg is ``envs.GYMNASIUM_COUNTERPARTS``."""
    assert gymnasium_registration.COUNTERPARTS == envs.GYMNASIUM_COUNTERPARTS


def test_installing_jaxpg_installs_the_start_up_file():
    """``pip install`` of jaxpg, editable (as the README's commands) or not, writes the start-up
    file into site-packages (setup.py's build hooks), so a fresh process that imports only
    Gymnasium finds every jaxpg id, having imported neither jaxpg nor JAX."""
    import sysconfig

    installed = Path(sysconfig.get_paths()["purelib"]) / gymnasium_registration.PTH_NAME
    assert installed.read_text(encoding="utf-8") == gymnasium_registration.pth_line()
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys, gymnasium; "
            "assert not any(m == 'jax' or m.startswith('jaxpg') for m in sys.modules), 'imported'; "
            "print(sorted(i for i in gymnasium.registry if i.startswith('jaxpg/'))[:2])",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd="/",
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "['jaxpg/Ant-v5', 'jaxpg/AntFast-v5']"


def test_a_script_that_never_imports_jaxpg_makes_a_jaxpg_id(tmp_path):
    """With the hook installed in a site directory (as ``python -m jaxpg.envs.gymnasium_registration
    install`` writes it into site-packages), ``import gymnasium`` registers every id while
    importing neither jaxpg nor JAX, and ``gymnasium.make("jaxpg/Walker2d-v5")`` then gives
    Gymnasium's start observation for the seed."""
    done = run_python(
        f"from jaxpg.envs import gymnasium_registration as r; r.main(['install', '--site-dir', {str(tmp_path)!r}])"
    )
    assert done.returncode == 0, done.stderr
    assert (tmp_path / gymnasium_registration.PTH_NAME).read_text().startswith("import ")
    script = f"""
        import site, sys
        site.addsitedir({str(tmp_path)!r})  # what Python does with site-packages at start-up
        import gymnasium
        import numpy as np
        assert not any(m == "jax" or m.startswith("jaxpg") for m in sys.modules), "imported at registration"
        ids = [i for i in gymnasium.registry if i.startswith("jaxpg/")]
        assert len(ids) == 23, ids
        env = gymnasium.make("jaxpg/Walker2d-v5")
        assert env.spec.max_episode_steps == 1000
        obs, _ = env.reset(seed=0)
        theirs, _ = gymnasium.make("Walker2d-v5").reset(seed=0)
        assert obs.dtype == theirs.dtype and np.allclose(obs, theirs, rtol=1e-5, atol=1e-5), (obs, theirs)
        print("ok")
    """
    done = run_python(script)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]


def test_registration_command_line_installs_uninstalls_and_refuses_an_unwritable_directory(tmp_path):
    assert gymnasium_registration.main(["install", "--site-dir", str(tmp_path)]) == 0
    assert (tmp_path / gymnasium_registration.PTH_NAME).exists()
    assert gymnasium_registration.main(["uninstall", "--site-dir", str(tmp_path)]) == 0
    assert not (tmp_path / gymnasium_registration.PTH_NAME).exists()
    done = run_python(
        "from jaxpg.envs import gymnasium_registration as r; "
        f"raise SystemExit(r.main(['install', '--site-dir', {str(tmp_path / 'missing')!r}]))"
    )
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        f"error: cannot write {tmp_path / 'missing' / gymnasium_registration.PTH_NAME}: No such file or directory"
    ]


@pytest.mark.parametrize("setting", ["dir", "off"])
def test_making_a_jaxpg_env_turns_the_compile_cache_on(tmp_path, setting):
    """A process that compiled a JAX program before making a jaxpg env (JAX settled its cache
    then) writes its next programs to jaxpg's cache (``JAXPG_COMPILATION_CACHE``), and to none
    with ``off``."""
    cache = tmp_path / "xla"
    script = """
        import jax, jax.numpy as jnp
        jnp.ones(3).sum().block_until_ready()  # JAX settles its cache at its first compilation
        import gymnasium
        import jaxpg.envs.gymnasium_api
        env = gymnasium.make("jaxpg/CartPole-v1")
        print(jax.config.jax_compilation_cache_dir)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)  # store even quick programs
        env.reset(seed=0)
        env.step(0)
    """
    done = run_python(script, env={"JAXPG_COMPILATION_CACHE": str(cache) if setting == "dir" else "off"})
    assert done.returncode == 0, done.stderr[-2000:]
    if setting == "dir":
        assert done.stdout.strip() == str(cache)
        assert len(list(cache.glob("*-cache"))) >= 2  # the reset and the step
    else:
        assert done.stdout.strip() == "None" and not cache.exists()
