"""What a command does first, before it plans: let JAX take GPU memory as it needs it, choose
MuJoCo's GL backend when it may draw a video, turn the compilation cache on, join the other
processes, check that JAX has a device, put back a run directory that a killed ``--overwrite``
left moved aside, and leave MuJoCo Warp out of a process that will not use it (``start``)."""

from __future__ import annotations

import os
import platform
import sys
from collections.abc import Mapping, MutableMapping, Sequence

import jax

from jaxpg import video as video_lib
from jaxpg.envs import mjx_import
from jaxpg.run.command.command_line import Experiment
from jaxpg.run.command.flags import UsageError, check_backend
from jaxpg.run.command.pre_flags import PreFlags, parse_pre_flags
from jaxpg.run.host import compile_cache, processes
from jaxpg.run.rundir import config_io, replacing


def start(argv: Sequence[str], experiment: Experiment, owns_process: bool = False) -> PreFlags:
    """Prepare this process for the command ``argv``; returns the flags it read (``PreFlags``),
    for planning. Each step comes where it must: the GL backend before MuJoCo is imported, the
    cache before the first compilation, ``jax.distributed`` before anything touches JAX's devices,
    the run directory's recovery before planning or the choice below reads it, the choice to
    import MJX without MuJoCo Warp (only when the command ``owns_process``: nothing else will run
    in it) before MJX is imported. Raises ``ValueError`` (one line) on bad flags or distributed
    settings or when JAX has no device, and ``OSError`` when the run directory cannot be put back
    in order. A command that ``owns_process`` also takes GPU memory on demand
    (``allocate_gpu_memory_on_demand``)."""
    if owns_process:
        allocate_gpu_memory_on_demand()  # before JAX starts its GPU backend (check_backend below)
    check_mujoco_gl()  # before anything imports MuJoCo, which refuses a bad value with a traceback
    pre = parse_pre_flags(argv, experiment)
    if pre.videos:
        video_lib.configure_gl()  # before MuJoCo is imported, and only when a video may be drawn
    compile_cache.enable()  # a second run of the same program loads it instead of compiling
    start_processes(pre)
    check_backend()
    recover_run_dir(pre)  # before a resumed run's impl is read from its directory
    if owns_process and steps_mjx_on_jax_only(pre, experiment, jax.default_backend()):
        mjx_import.leave_out_warp()  # most of `import mujoco.mjx` on two CPU cores (BENCHMARKS.md, "CPU")
    return pre


def mujoco_gl_values(system: str | None = None) -> tuple[str, ...]:
    """The values of ``MUJOCO_GL`` that ``import mujoco`` accepts on ``system`` (``platform.system()``),
    case and surrounding spaces aside: off, on, GLFW, and the platform's own backends."""
    system = platform.system() if system is None else system
    values = ("disable", "disabled", "off", "false", "0", "enable", "enabled", "on", "true", "1", "glfw", "")
    return values + {"Linux": ("glx", "egl", "osmesa"), "Windows": ("wgl",), "Darwin": ("cgl",)}.get(system, ())


def check_mujoco_gl(environ: Mapping[str, str] = os.environ, system: str | None = None) -> None:
    """``UsageError`` (one line) when ``MUJOCO_GL`` holds a value MuJoCo refuses at import on
    ``system`` (a ``RuntimeError`` traceback from deep inside the first env), whether or not a
    video is drawn."""
    value = environ.get("MUJOCO_GL")
    if value is not None and value.lower().strip() not in mujoco_gl_values(system):
        choices = ", ".join(v for v in mujoco_gl_values(system) if v)
        raise UsageError(f"MUJOCO_GL={value} is not a value MuJoCo accepts ({choices}); unset it or pick one of those")


PREALLOCATE_VARIABLE = "XLA_PYTHON_CLIENT_PREALLOCATE"


def allocate_gpu_memory_on_demand(environ: MutableMapping[str, str] = os.environ) -> str:
    """Set ``XLA_PYTHON_CLIENT_PREALLOCATE=false`` in ``environ`` unless it is set; returns its value.

    By default JAX's GPU client reserves 75 % of the GPU's memory when it makes its first buffer.
    On a large GPU that first buffer took seconds, and a fraction of one with the variable
    false (``python benchmarks/card_command.py memory``, docs/benchmarks_archive.md AW); the
    card's warm run got faster, and Humanoid's PPO trained at the same
    env steps/s either way (BENCHMARKS.md, "Where a warm run's time goes"). JAX reads the variable
    when it starts its GPU backend, so this must come before anything touches a device; processes
    started from this one inherit it. A value you set yourself is kept."""
    environ.setdefault(PREALLOCATE_VARIABLE, "false")
    return environ[PREALLOCATE_VARIABLE]


def steps_mjx_on_jax_only(pre: PreFlags, experiment: Experiment, backend: str) -> bool:
    """Whether the command will step MJX with its JAX implementation only, so that MJX can be
    imported without MuJoCo Warp (``jaxpg.envs.mjx_import``): ``--impl jax``, or a fresh run with no
    ``impl`` from the flags or the experiment on a ``backend`` (JAX's default) other than ``"gpu"``,
    where the default is jax. A resumed run (``--resume``) without ``--impl`` reads the ``impl`` its
    run directory saved; one whose configuration cannot be read keeps Warp (planning then reports
    what is wrong with it)."""
    impl = pre.impl or experiment.env_kwargs.get("impl")
    if impl is None and pre.resume is not None:
        return saved_run_steps_mjx_on_jax_only(pre.resume, backend)
    return mjx_import.runs_jax_only(impl, backend)


def saved_run_steps_mjx_on_jax_only(run_dir: str, backend: str) -> bool:
    """Whether the run saved in ``run_dir`` steps MJX with its JAX implementation only on a
    ``backend``: the ``impl`` its ``config.json`` saved, or none and the default there. False when
    the configuration cannot be read (whatever reads it next reports why)."""
    try:
        impl = config_io.RunConfig.load(run_dir).env_kwargs.get("impl")
    except (OSError, ValueError):
        return False
    return mjx_import.runs_jax_only(impl, backend)


def start_processes(pre: PreFlags) -> None:
    """``jax.distributed.initialize`` when the flags or the environment name several processes;
    before anything else touches JAX's devices. ``DistributedError`` (one line) on bad settings or
    an unreachable coordinator."""
    config = processes.DistributedConfig.resolve(
        pre.coordinator_address, pre.num_processes, pre.process_id, timeout_s=pre.distributed_timeout
    )
    if config is not None:
        processes.initialize(config)


def recover_run_dir(pre: PreFlags) -> None:
    """Before planning: put back the run that an ``--overwrite`` of the command's run directory
    (``--run-dir`` or ``--resume``) moved aside, if its process ended before the new run's first
    checkpoint, or point to it (``replacing.recover_replaced``). Process 0 alone; the others wait."""
    if pre.target is not None and processes.is_primary():
        for line in replacing.recover_replaced(pre.target):
            print(line, file=sys.stderr)
    processes.barrier("jaxpg: run directory recovered")
