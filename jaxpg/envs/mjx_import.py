"""How ``mujoco.mjx`` is imported: with MuJoCo Warp (MJX's GPU physics, ``impl="warp"``) or without.

Importing MJX imports MuJoCo Warp whenever the ``warp-lang`` package is installed, whether or not
the process will use it: on two CPU cores that is most of what ``import mujoco.mjx`` takes
(BENCHMARKS.md, "CPU": start-up without MuJoCo Warp; ``benchmarks/card_command.py startup``). A process
that will only step MJX's JAX implementation (a command on a machine without a GPU, or
``--impl jax``) can leave it out by setting the environment variable ``JAXPG_MJX_WARP=off`` before
MJX is first imported; jaxpg's command lines do so themselves (``jaxpg.run.command.startup``). MJX then
runs as it does without ``warp-lang``, and asking that process for ``impl="warp"`` is a
``ValueError`` that says why.

MJX also imports ``trimesh`` and ``scipy.spatial``, which it uses only to take the convex hull of a
model's meshes; no task of jaxpg's has one. Importing them is a visible part of a command's
start (BENCHMARKS.md, "CPU": start-up without MuJoCo Warp; ``benchmarks/card_command.py startup``).
``import_mjx`` imports MJX with a stand-in for each (``DeferredModule``) that imports the real
module the first time MJX uses it, so a process that converts no mesh imports neither.

Kept free of MuJoCo imports, so that a command can decide before MJX is imported.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import sys
import types
from collections.abc import Iterator, Mapping
from typing import Any

WARP_VARIABLE = "JAXPG_MJX_WARP"
_OFF = ("off", "0", "no", "false")


def warp_installed() -> bool:
    """True when the ``warp-lang`` package (MuJoCo Warp's runtime) can be imported."""
    return importlib.util.find_spec("warp") is not None


def warp_left_out(environ: Mapping[str, str] | None = None) -> bool:
    """Whether ``environ`` (default: this process's environment) asks MJX to be imported without
    MuJoCo Warp (``JAXPG_MJX_WARP=off``)."""
    environ = os.environ if environ is None else environ
    return environ.get(WARP_VARIABLE, "").strip().lower() in _OFF


def runs_jax_only(impl: str | None, backend: str) -> bool:
    """Whether MJX will step with its JAX implementation: ``impl`` as asked, or with ``None`` the
    default (``jaxpg.envs.mjx_env.default_impl``: warp on a ``backend``, JAX's, of ``"gpu"``)."""
    return (impl or ("warp" if backend == "gpu" else "jax")) == "jax"


def leave_out_warp() -> None:
    """Set ``JAXPG_MJX_WARP=off`` for this process (and those it starts), unless it is set already
    or MJX is imported (the choice is made then). For a command that nothing else runs beside,
    once it knows it will step MJX on JAX only."""
    if WARP_VARIABLE not in os.environ and "mujoco.mjx" not in sys.modules:
        os.environ[WARP_VARIABLE] = "off"


class DeferredModule(types.ModuleType):
    """What MJX's ``import NAME`` finds while ``import_mjx`` imports MJX: any attribute is the real
    module's, imported on first use, except the classes named in ``classes`` (trimesh's
    ``Trimesh``, which MJX's ``mesh.py`` names in an annotation when it is imported): classes whose
    instances (and ``isinstance`` checks) are the real module's."""

    def __init__(self, name: str, classes: tuple[str, ...] = ()) -> None:
        super().__init__(name)
        for cls in classes:
            setattr(self, cls, _DeferredClass(cls, (), {"module": self}))

    def __getattr__(self, name: str) -> Any:  # attributes other than the deferred classes
        return getattr(self.real(), name)

    def real(self) -> types.ModuleType:
        """The real module, imported now if it was not."""
        real = sys.modules.get(self.__name__)
        if real is None or real is self:
            sys.modules.pop(self.__name__, None)
            real = importlib.import_module(self.__name__)
        return real


class _DeferredClass(type):
    """A class of a ``DeferredModule``: calling it builds, and ``isinstance`` asks, the real class."""

    def __call__(cls, *args: Any, **kwargs: Any) -> Any:
        return getattr(cls.module.real(), cls.__name__)(*args, **kwargs)

    def __instancecheck__(cls, instance: Any) -> bool:
        return isinstance(instance, getattr(cls.module.real(), cls.__name__))


DEFERRED_BY_MJX = (("trimesh", ("Trimesh",)), ("scipy.spatial", ()))
"""The modules ``import_mjx`` defers, ``(name, deferred classes)``: MJX's ``mesh.py`` imports them
for the convex hulls of meshes."""


def _installed(name: str) -> bool:
    """Whether module ``name`` can be imported (its parent package, if any, is imported to tell)."""
    try:
        return importlib.util.find_spec(name) is not None
    except ImportError:  # the parent package is missing
        return False


@contextlib.contextmanager
def _mesh_modules_deferred() -> Iterator[None]:
    """While MJX is imported, ``import NAME`` finds a ``DeferredModule`` for each module of
    ``DEFERRED_BY_MJX`` (unless it is imported already or not installed); afterwards ``import
    NAME`` imports the module itself."""
    deferred = []
    for name, classes in DEFERRED_BY_MJX:
        if name not in sys.modules and _installed(name):
            sys.modules[name] = DeferredModule(name, classes)
            deferred.append(name)
    try:
        yield
    finally:
        for name in deferred:
            if isinstance(sys.modules.get(name), DeferredModule):
                del sys.modules[name]


def import_mjx() -> tuple[Any, bool]:
    """``(mujoco.mjx, with_warp)``, imported quietly: without warp-lang MJX prints "Failed to
    import warp" on import (its JAX implementation works regardless), and with it Warp prints a
    banner and a line per compiled module unless ``warp.config.quiet`` is set. ``with_warp`` is
    False when warp-lang is missing or ``warp_left_out()`` (and warp was not imported already)."""
    if "mujoco.mjx" in sys.modules:  # imported before jaxpg: as it was
        mjx_warp = sys.modules.get("mujoco.mjx.warp")
        return sys.modules["mujoco.mjx"], bool(getattr(mjx_warp, "WARP_INSTALLED", False))
    leave_out = warp_left_out() and "warp" not in sys.modules
    if warp_installed() and not leave_out:
        import warp

        warp.config.quiet = True  # warp-lang 1.18
        if hasattr(warp, "LOG_WARNING"):
            warp.config.log_level = warp.LOG_WARNING  # warp-lang 1.19 replaced ``quiet`` by a log level
        with _mesh_modules_deferred():
            from mujoco import mjx

        return mjx, True
    hidden = leave_out and warp_installed()
    if hidden:
        sys.modules["warp"] = None  # type: ignore[assignment]  # `import warp` raises ImportError
    try:
        with contextlib.redirect_stdout(io.StringIO()), _mesh_modules_deferred():
            from mujoco import mjx
    finally:
        if hidden:
            del sys.modules["warp"]  # a later `import warp` (not MJX's) works as usual
    return mjx, False
