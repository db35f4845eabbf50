"""Test-wide settings, applied before any test module imports MuJoCo, and the run directory that
the tests of damaged checkpoints share (``pristine_run``, ``run_copy``)."""

import dataclasses
import json
import os
import shutil
from pathlib import Path
from typing import Any

import jax
import pytest

from jaxpg import algos, video, xla_flags
from jaxpg.run.checkpoints.checkpointer import Checkpointer
from jaxpg.run.rundir import config_io, layout

# Two XLA:CPU options for every test process and every process a test starts (they inherit the
# environment; the notebooks' kernels too). The tests are compilation-bound on the CPU, and both make
# compilation faster:
# - the legacy emitters in place of the fusion emitters: on two cores they compiled MJX's Hopper step
#   in 9.1 s against 15.5 s, the inverted pendulum's in 4.4 s against 6.3 s and Walker2d's
#   command-line training block in 21.3 s against 27.1 s; the whole run took 2804 s against 3441 s.
#   (jaxpg itself picks them only for Pusher's programs: jaxpg.envs.compile_options.)
# - LLVM's optimisation level 1 in place of XLA's default: Hopper's NPG update (16 envs x 64 steps)
#   compiled in 16.9 and 18.2 s against 24.6 and 23.0 s and ran at the same speed (208-243 ms against
#   251 ms); Pong's A2C block (4 seeds x 50 iterations, as test_pong's learning test then had) in 6.2 s against
#   12.0 s, running in 7.41 s against 7.39 s; Humanoid's command-line smoke run took 52.6 s against 60.3 s.
# Both decide how XLA generates code, not what it computes, though rounding may differ.
# Set before JAX starts a backend, which reads XLA_FLAGS once (the imports above start none). Only
# those this XLA knows: an unknown flag ends the process, and XLA in jaxlib 0.11.2 has no
# xla_cpu_use_fusion_emitters (every test failed there). Tried once, in pytest's first process; the
# xdist workers and every process a test starts inherit the result.
# Tried and rejected (2 cores, 2026-12-01): LLVM's level 0 compiled Pusher's smoke-run block in 19.8 s
# against 25.6 s, but the pendulum's NPG and PPO learning tests ran 33.9 and 35.2 s against 26.4 and 15.6 s.
# JAX's persistent cache shared by the whole session (and the notebooks' kernels) saved nothing measurable:
# notebook 05 added 381 programs to notebook 01's 159, and test_envs.py with and without it, side by
# side on one core each, had run the same number of tests (62, 63 of 98) after 20 minutes.
# Tried and rejected (2 cores, 2026-12-02): xla_llvm_disable_expensive_passes on top of both options: Pusher's smoke
# run 48.2 s against 53.2 s, but the pendulum's NPG and PPO learning tests 34.4 and 20.8 s against 30.2 and 19.3 s.
# Tried and undone (2026-12-02): Pusher planned, not trained, from the command line (its smoke run took 97-104 s in
# the suite). test_envs.py's first parity test then waited 136 s for the float64 parity worker, against 50 s: the smoke
# runs overlap that worker, so the module took no less time. The suite took 1987 s against 1943 s before both this
# and Pong's cut to three seeds (and 2087 s with a per-test timing plugin): the machine's drift hides either.

TEST_XLA_OPTIONS = (("xla_cpu_use_fusion_emitters", "false"), ("xla_backend_optimization_level", "1"))
if os.environ.get("JAXPG_TEST_XLA_OPTIONS_SET") != "1":
    os.environ["XLA_FLAGS"] = xla_flags.with_options(
        os.environ.get("XLA_FLAGS", ""), xla_flags.accepted_options(TEST_XLA_OPTIONS)
    )
    os.environ["JAXPG_TEST_XLA_OPTIONS_SET"] = "1"


# MuJoCo picks its OpenGL backend at first import (none of the imports above imports it:
# tests/test_imports.py): jaxpg.video.configure_gl sets MUJOCO_GL to a backend whose library loads
# (OSMesa from Debian's libosmesa6, which .ci/run installs, or EGL), and to none on a machine
# without either, so that `import mujoco` still works there and the rendering tests skip.
video.configure_gl()

# jaxpg's command lines keep compiled programs in a persistent cache (jaxpg.run.host.compile_cache): give the
# test session a fresh one, so tests never read programs compiled by an older checkout.
if "JAXPG_COMPILATION_CACHE" not in os.environ:
    import tempfile

    os.environ["JAXPG_COMPILATION_CACHE"] = tempfile.mkdtemp(prefix="jaxpg-xla-cache-")


# The modules that took longest on two cores, longest first (the test time of a full run's
# --durations, 2026-11-28: test_envs 1132 s, the notebooks 488 s, test_gymnasium_api 381 s,
# test_pong 363 s, test_reliability 315 s, test_learning 265 s; the next took 173 s; the run
# before had test_gymnasium_api third as well). pytest-xdist hands whole modules (--dist loadfile)
# to its two workers in collection order: collected alphabetically, test_pong and test_reliability
# started last and one worker finished them while the other idled.
LONGEST_MODULES = (
    "test_envs.py",
    "test_notebooks.py",
    "test_gymnasium_api.py",
    "test_pong.py",
    "test_reliability.py",
    "test_learning.py",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Collect ``LONGEST_MODULES`` first, in that order; the rest (and each module's tests) keep
    their order."""
    items.sort(
        key=lambda item: (
            LONGEST_MODULES.index(item.path.name) if item.path.name in LONGEST_MODULES else len(LONGEST_MODULES)
        )
    )


_CACHE_DIR_AT_START: list = []  # JAX's jax_compilation_cache_dir when the first test starts


@pytest.fixture(autouse=True)
def _persistent_compilation_cache_left_as_found():
    """``jaxpg.run.command.main.main`` turns JAX's persistent compilation cache on for the rest of its process
    (so that a second run loads its programs). Tests that run the command line in this process
    (module fixtures too) would leave it on for every later test, which then writes each program it
    compiles to disk: after each test the cache is set back to how the session found it, so that
    every test compiles as it would alone."""
    import jax
    from jax.experimental.compilation_cache import compilation_cache

    if not _CACHE_DIR_AT_START:
        _CACHE_DIR_AT_START.append(jax.config.jax_compilation_cache_dir)
    yield
    if jax.config.jax_compilation_cache_dir != _CACHE_DIR_AT_START[0]:
        jax.config.update("jax_compilation_cache_dir", _CACHE_DIR_AT_START[0])
        compilation_cache.reset_cache()


@pytest.fixture(autouse=True, scope="module")
def _compiled_programs_freed_after_each_module():
    """Free every compiled program after each test module: a single pytest process compiles
    hundreds of MJX programs, and late in the suite XLA's CPU compiler aborted (twice, at
    ``tests/test_train.py``) in a process that still held all of them."""
    yield
    import gc

    import jax

    jax.clear_caches()
    gc.collect()


# --------------------------------------------------------------------------- a checkpointed run


@dataclasses.dataclass(frozen=True)
class PristineRun:
    """A cartpole NPG run directory written from the algorithm's ``init``, nothing trained:
    ``config.json``, ``metrics.jsonl`` of iterations 1-4 (a resume needs the metrics of the
    iterations its checkpoint holds) and checkpoints 2 and 4, scored 2 and 4."""

    path: Path
    initial: Any  # the TrainState of ``init``

    def state(self, step: int) -> Any:
        """The state checkpoint ``step`` holds: ``initial`` with the policy parameters moved by
        ``0.01 * step``, so that each checkpoint differs."""
        return self.initial.replace(params=jax.tree.map(lambda x: x + 0.01 * step, self.initial.params))


@pytest.fixture(scope="module")
def pristine_run(tmp_path_factory) -> PristineRun:
    """A ``PristineRun``, written once per module; tests damage copies of it (``run_copy``).
    Nothing is compiled beyond what ``init`` and the checkpoint's ``jax.eval_shape`` trace."""
    module = algos.get("npg")
    config = module.Config(num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), value_batch_size=8)
    run = config_io.RunConfig(
        task="cartpole",
        algo="npg",
        config=config_io.config_to_dict(config),
        seeds=[0],
        iterations=4,
        checkpoint_every=2,
    )
    path = tmp_path_factory.mktemp("runs") / "run"
    path.mkdir()
    run.save(path)
    rows = [{"iteration": i, "seed": 0, "env_steps": 32.0 * i, "wall_time_s": float(i)} for i in range(1, 5)]
    (path / layout.METRICS_FILE).write_text("".join(json.dumps(r) + "\n" for r in rows))
    pristine = PristineRun(path, module.init(jax.random.PRNGKey(0), run.make_env(), config))
    ckpt = Checkpointer(path / layout.CHECKPOINT_DIR, keep=None, create=True)
    for step in (2, 4):
        ckpt.save(
            step, pristine.state(step), score=float(step), info={"task": run.task, "algo": run.algo, "seeds": [0]}
        )
    ckpt.close()
    return pristine


@pytest.fixture
def run_copy(pristine_run: PristineRun, tmp_path: Path) -> Path:
    """A fresh copy of ``pristine_run``'s directory, for one test to damage."""
    path = tmp_path / "run"
    shutil.copytree(pristine_run.path, path)
    return path
