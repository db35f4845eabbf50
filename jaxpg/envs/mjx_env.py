"""Base class of the MuJoCo MJX tasks: model loading, physics settings, implementation choice."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

import jax
import jax.numpy as jnp
import mujoco

from jaxpg.envs import mjx_import
from jaxpg.envs.base import Env, expand_like

ASSETS = Path(__file__).parent / "assets"

Fidelity = Literal["fast", "gymnasium"]
Impl = Literal["jax", "warp"]

# Solver settings of the "fast" fidelity: the semi-implicit Euler integrator and a short Newton solve.
# On a GPU these step many times faster than Gymnasium's RK4 with the default solver (BENCHMARKS.md,
# "Raw simulation and the env").
FAST_SOLVER_ITERATIONS = 4
FAST_LS_ITERATIONS = 8

# MuJoCo's integration state (``mjSTATE_INTEGRATION``): every field of the physics data that a
# physics step reads. It recomputes all others from these (``mj_step`` starts with ``mj_forward``).
INTEGRATION_STATE = (
    "time",
    "qpos",
    "qvel",
    "act",
    "history",
    "qacc_warmstart",
    "plugin_state",
    "ctrl",
    "qfrc_applied",
    "xfrc_applied",
    "eq_active",
    "mocap_pos",
    "mocap_quat",
    "userdata",
)


_mjx_import_started = time.perf_counter()
mjx, _MJX_HAS_WARP = mjx_import.import_mjx()
# ``time.perf_counter()`` around the import, for the end-of-run report (``jaxpg.run.command.startup_times``).
MJX_IMPORT_SPAN = (_mjx_import_started, time.perf_counter())


def warp_available() -> bool:
    """True when MuJoCo Warp can step MJX in this process: warp-lang is installed and MJX was
    imported with it (not left out by ``JAXPG_MJX_WARP=off``: ``jaxpg.envs.mjx_import``)."""
    return _MJX_HAS_WARP


def default_impl() -> Impl:
    """MJX implementation used when a task is made without ``impl``: warp on a CUDA GPU, else jax."""
    return "warp" if jax.default_backend() == "gpu" and warp_available() else "jax"


def load_model(xml_file: str, fidelity: Fidelity, total_mass: float | None = None) -> mujoco.MjModel:
    """Compile ``envs/assets/<xml_file>`` (or ``xml_file`` itself when it is an MJCF string) and
    apply the physics settings of ``fidelity``.

    ``"gymnasium"`` keeps the file's integrator and solver (identical to Gymnasium's model), except
    that a file asking for the PGS solver (Humanoid's), which MJX lacks, gets Newton in both fidelities;
    ``"fast"`` switches to Euler with ``FAST_SOLVER_ITERATIONS`` Newton iterations and
    ``FAST_LS_ITERATIONS`` line-search iterations, which MJX steps an order of magnitude faster.
    ``total_mass`` scales every body's mass and inertia to that total (``mj_setTotalmass``, then
    ``mj_setConst``): the same model, to the bit, as the compiler's deprecated ``settotalmass``.
    """
    if fidelity not in ("fast", "gymnasium"):
        raise ValueError(f"unknown fidelity {fidelity!r}: expected 'fast' or 'gymnasium'")
    if xml_file.lstrip().startswith("<"):
        model = mujoco.MjModel.from_xml_string(xml_file)
    else:
        model = mujoco.MjModel.from_xml_path(str(ASSETS / xml_file))
    if total_mass is not None:
        mujoco.mj_setTotalmass(model, total_mass)
        mujoco.mj_setConst(model, mujoco.MjData(model))
    if model.opt.solver == mujoco.mjtSolver.mjSOL_PGS:
        # MJX has no PGS (mjx.put_model raises NotImplementedError): Newton, its default, in its place.
        model.opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    if fidelity == "fast":
        model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
        model.opt.iterations = FAST_SOLVER_ITERATIONS
        model.opt.ls_iterations = FAST_LS_ITERATIONS
    return model


def planar_position_metrics(qpos: jax.Array) -> dict[str, jax.Array]:
    """``x_position``, ``y_position``, ``distance_from_origin`` (of ``qpos[:2]``) and ``task_score``
    (``x_position``), ``[]`` each: the position terms of Gymnasium's ``info`` for a body whose first
    two coordinates are its x and y (Swimmer's slides, Ant's and Humanoid's free joint)."""
    return {
        "x_position": qpos[0],
        "y_position": qpos[1],
        "distance_from_origin": jnp.linalg.norm(qpos[:2]),
        "task_score": qpos[0],
    }


class MjxEnv(Env):
    """A task simulated by MJX.

    Args:
      xml_file: MJCF file under ``jaxpg/envs/assets``, or an MJCF string (starting with ``<``).
      frame_skip: physics steps per env step (``dt = frame_skip * timestep``).
      fidelity: ``"fast"`` (default; Euler, few solver iterations) or ``"gymnasium"``.
      impl: ``"jax"`` or ``"warp"`` (MuJoCo Warp behind MJX); ``None`` picks ``default_impl()``.
      max_episode_steps: time limit (1000 for the Gymnasium v5 tasks).
      total_mass: scale the model's masses to this total (see ``load_model``); ``None`` keeps them.
      naconmax, njmax: per-env contact and constraint capacities for the warp implementation.
      max_batch: warp only: the most envs stepped together in one vmapped call (all nested vmaps,
        e.g. seeds x envs, multiplied). MuJoCo Warp keeps constraint rows per env (``njmax``) but
        one contact buffer for the whole batch, which MJX does not batch under ``vmap``; it gets
        ``naconmax * max_batch`` slots. A larger batch drops contacts (Warp prints an overflow
        warning); a smaller one only wastes a little memory and idle GPU threads.
      warp_graph_mode: CUDA-graph capture of the warp kernels, a ``warp.JaxCallableGraphMode``
        name (any case): ``"WARP"`` (MJX's GPU default), ``"WARP_STAGED"``, ``"WARP_STAGED_EX"``,
        ``"JAX"`` (MJX's CPU default) or ``"NONE"``; ``None`` keeps MJX's default
        (``benchmarks/step_latency.py`` times each).

    ``cpu_fusion_emitters``: false for a task whose kinematic chain is so deep that XLA:CPU's
    fusion emitters make its step exponentially slow; its programs are then compiled with the
    legacy emitters on the CPU (``jaxpg.envs.compile_options``).

    ``derived_fields_read``: the derived fields (``xpos``, ``ten_length`` ...) a task reads before
    its physics step or reports in Gymnasium's ``info``; an automatic reset selects them with the
    integration state (``select_physics``).
    """

    cpu_fusion_emitters: bool = True
    derived_fields_read: tuple[str, ...] = ()

    def __init__(
        self,
        xml_file: str,
        frame_skip: int,
        fidelity: Fidelity = "fast",
        impl: Impl | None = None,
        max_episode_steps: int = 1000,
        naconmax: int = 16,
        njmax: int = 64,
        max_batch: int = 8192,
        warp_graph_mode: str | None = None,
        total_mass: float | None = None,
    ):
        impl = impl or default_impl()
        if impl not in ("jax", "warp"):
            raise ValueError(f"unknown impl {impl!r}: expected 'jax' or 'warp'")
        if impl == "warp" and not warp_available():
            if mjx_import.warp_installed():
                raise ValueError(
                    f"impl='warp': this process imported MJX without MuJoCo Warp ({mjx_import.WARP_VARIABLE}=off); "
                    "start it without that setting"
                )
            raise ValueError("impl='warp' needs the warp-lang package: pip install 'jaxpg[warp]'")
        self.fidelity = fidelity
        self.impl = impl
        self.frame_skip = frame_skip
        self.max_episode_steps = max_episode_steps
        self.mj_model = load_model(xml_file, fidelity, total_mass)
        self.dt = float(self.mj_model.opt.timestep) * frame_skip
        put_kwargs: dict[str, Any] = {}
        if impl == "warp" and warp_graph_mode is not None:
            import warp

            put_kwargs["graph_mode"] = getattr(warp.JaxCallableGraphMode, warp_graph_mode.upper())
        self.mjx_model = mjx.put_model(self.mj_model, impl=impl, **put_kwargs)
        if impl == "warp":
            # Overflows are counted in metrics["physics_overflow"], not printed by every kernel.
            opt = self.mjx_model.opt
            self.mjx_model = self.mjx_model.replace(opt=opt.replace(_impl=opt._impl.replace(warn_overflow=0)))
        # naconmax is per batch in MJX's warp Data (see `max_batch`), njmax per env.
        make_kwargs: dict[str, Any] = {}
        if impl == "warp":
            make_kwargs = {"naconmax": naconmax * max_batch, "njmax": njmax}
        self._data0 = mjx.make_data(self.mj_model, impl=impl, **make_kwargs)
        self._public_fields = frozenset(f.name for f in dataclasses.fields(self._data0) if f.name != "_impl")
        self.init_qpos = jnp.asarray(self.mj_model.qpos0, jnp.float32)
        self.init_qvel = jnp.zeros(self.mj_model.nv, jnp.float32)
        self.nq, self.nv = self.mj_model.nq, self.mj_model.nv
        self._substep: tuple[Any, Callable[[Any, Any], Any]] | None = None  # see substep()

    def physics_state(self, qpos: jax.Array, qvel: jax.Array, forward: bool = False, kinematics: bool = False) -> Any:
        """An ``mjx.Data`` at ``qpos [nq]``, ``qvel [nv]``, time 0, no control, cold warm start.

        Quantities derived from the positions are only recomputed on request, since ``mjx.step``
        recomputes them all anyway: ``forward`` runs the whole forward pass (contacts, constraint
        forces ...); ``kinematics`` only the kinematic pass (the frames of bodies, geoms and sites:
        ``xpos``, ``xquat``, ``site_xpos`` ...), which is all a task whose observation reads body
        positions needs, at a fraction of the cost in every automatic reset. Tasks whose
        observation reads only ``qpos``/``qvel`` need neither, and their resets cost almost nothing.
        """
        data = self._data0.replace(qpos=qpos.astype(self._data0.qpos.dtype), qvel=qvel.astype(self._data0.qvel.dtype))
        if forward:
            data = mjx.forward(self.mjx_model, data)
        elif kinematics:
            data = mjx.kinematics(self.mjx_model, data)
        return data

    def start_state(self, qpos: jax.Array, qvel: jax.Array) -> tuple[Any, jax.Array, dict[str, jax.Array]]:
        """What ``_reset`` returns (``(data, obs, metrics)``) once it has drawn ``qpos [nq]`` and
        ``qvel [nv]``: a reset to a given start state (Gymnasium's start states in
        ``jaxpg.envs.gymnasium_api``). Every MJX task implements it."""
        raise NotImplementedError(f"{type(self).__name__} has no start_state")

    def physics_step(self, data: Any, ctrl: jax.Array) -> Any:
        """Set ``ctrl [nu]`` and run ``frame_skip`` MJX steps.

        With MuJoCo Warp the overflow flags (solver iteration limit, contact or constraint
        capacity) are cleared first, so that ``_physics_overflow`` reports this env step alone.
        """
        data = data.replace(ctrl=ctrl.astype(data.ctrl.dtype))
        if self.impl == "warp":
            data = data.replace(_impl=data._impl.replace(overflow=jnp.zeros_like(data._impl.overflow)))
        return jax.lax.fori_loop(0, self.frame_skip, self.substep(), data)

    def substep(self) -> Callable[[Any, Any], Any]:
        """``(i, data) -> data``, one MJX step of ``mjx_model``: the body of ``physics_step``'s loop.

        The same function object for as long as ``mjx_model`` stays the same (tasks may replace it
        while they are built). JAX keeps what it traced of a loop body by the function, so every
        program that steps this env (training blocks of any size, the evaluation) reuses one trace
        of the MJX step instead of tracing it again."""
        model = self.mjx_model
        if self._substep is None or self._substep[0] is not model:
            self._substep = (model, lambda _, data: mjx.step(model, data))
        return self._substep[1]

    def select_physics(self, pick_new: jax.Array, new: Any, old: Any) -> Any:
        """The ``mjx.Data`` ``new`` where ``pick_new`` (as ``Env.select_physics``), else ``old``,
        in the fields a step reads: ``INTEGRATION_STATE`` and the task's ``derived_fields_read``.

        The other derived fields (about 150 arrays per env with MuJoCo Warp) keep ``old``'s values
        until the next physics step recomputes them, so after an automatic reset ``data.xpos`` and
        the like describe the ended episode's last state for one step; observations, rewards and
        ``info`` are unaffected. Selecting every field (MJX's ``Data.where``) made Reacher, the
        suite's cheapest physics step, slower (BENCHMARKS.md, "The MuJoCo suite"). MJX keeps MuJoCo Warp's
        contact buffer, shared by the batch, in ``_impl``; it is never selected.
        """

        def field(data: Any, name: str) -> jax.Array:
            return getattr(data if name in self._public_fields else data._impl, name)

        chosen = {}
        for name in INTEGRATION_STATE + self.derived_fields_read:
            kept = field(old, name)
            chosen[name] = jnp.where(expand_like(pick_new, kept), field(new, name), kept)
        data = old.replace(**{n: v for n, v in chosen.items() if n in self._public_fields})
        private = {n: v for n, v in chosen.items() if n not in self._public_fields}
        return data.replace(_impl=data._impl.replace(**private)) if private else data

    def _physics_overflow(self, data: Any) -> jax.Array:
        """``[]`` float32: 1 when MuJoCo Warp flagged an overflow in the last ``physics_step`` (its
        Newton solver stopped at the iteration limit, or a contact/constraint buffer was full)."""
        if self.impl != "warp":
            return jnp.zeros((), jnp.float32)
        return jnp.any(data._impl.overflow != 0).astype(jnp.float32)

    def _physics_finite(self, data: Any) -> jax.Array:
        return jnp.all(jnp.isfinite(data.qpos)) & jnp.all(jnp.isfinite(data.qvel))

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(obs={self.observation_size}, act={self.action_size}, "
            f"fidelity={self.fidelity!r}, impl={self.impl!r}, dt={self.dt})"
        )
