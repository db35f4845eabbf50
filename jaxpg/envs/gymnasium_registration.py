"""jaxpg's Gymnasium ids (``jaxpg/Hopper-v5`` ...), registered without importing jaxpg, JAX or
MuJoCo, and a start-up hook that registers them in every process of a Python environment.

Gymnasium 1.x reads no plugin entry points (its 0.26-0.29 did): an id resolves only once code that
registers it ran in the process. ``import jaxpg.envs.gymnasium_api`` registers them, and so does
naming that module in the id (``gymnasium.make("jaxpg.envs.gymnasium_api:jaxpg/Hopper-v5")``).
For scripts that take a bare id, every ``pip install`` of jaxpg (regular or editable) writes
``PTH_NAME`` into the environment's site-packages (``setup.py``'s build hooks call ``install``);
by hand, e.g. where jaxpg is only on ``PYTHONPATH``::

    python -m jaxpg.envs.gymnasium_registration install     # uninstall: the same with uninstall

Python runs that file's one line at every start: it loads this module on its own (``jaxpg``'s
package, with its JAX settings, stays unimported) and waits for ``gymnasium`` to be imported;
right after, the ids are registered (``register_ids``). A process that never imports Gymnasium
pays a file lookup; one that does, the registration of a few dozen specs. Making an env imports
jaxpg then, as the ids' entry points say.

This module imports nothing of jaxpg and must stay so.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import sys
import sysconfig
from pathlib import Path
from types import ModuleType
from typing import Any


def _builtin_counterparts() -> dict[str, tuple[str, int]]:
    """jaxpg task -> (the id of the Gymnasium env it reproduces, Gymnasium's step limit), read from
    ``tasks.py`` beside this file, loaded by its path: it imports only ``dataclasses``, so
    registering still imports nothing of jaxpg's package (and none of its JAX settings)."""
    spec = importlib.util.spec_from_file_location("_jaxpg_task_table", Path(__file__).with_name("tasks.py"))
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return dict(module.GYMNASIUM_COUNTERPARTS)


COUNTERPARTS: dict[str, tuple[str, int]] = _builtin_counterparts()

# Tasks with no physics fidelity to choose (pure JAX, the same equations as Gymnasium's).
NO_FIDELITY = frozenset({"cartpole"})

API_MODULE = "jaxpg.envs.gymnasium_api"
PTH_NAME = "jaxpg-gymnasium-ids.pth"


def fast_id(gym_id: str) -> str:
    """The id of ``gym_id``'s task in jaxpg's fast physics: ``"jaxpg/Hopper-v5"`` ->
    ``"jaxpg/HopperFast-v5"``."""
    name, version = gym_id.rsplit("-v", 1)
    return f"{name}Fast-v{version}"


def class_name(theirs: str) -> str:
    """The name of the env class of Gymnasium's id ``theirs`` (``"Hopper-v5"`` -> ``"HopperEnv"``),
    as Gymnasium names its own; ``jaxpg.envs.gymnasium_api`` defines one per task, and
    ``<Name>VectorEnv`` for the batched env."""
    return theirs.rsplit("-v", 1)[0] + "Env"


def id_arguments(gym_id: str) -> tuple[str, dict[str, Any]] | None:
    """``(task, keywords)`` that jaxpg id ``gym_id`` makes its task with (its fidelity), or
    ``None`` for an id that is not jaxpg's."""
    for task, (theirs, _) in COUNTERPARTS.items():
        ours = f"jaxpg/{theirs}"
        if gym_id == ours:
            return task, ({} if task in NO_FIDELITY else {"fidelity": "gymnasium"})
        if gym_id == fast_id(ours) and task not in NO_FIDELITY:
            return task, {"fidelity": "fast"}
    return None


def register_ids(gymnasium: ModuleType) -> None:
    """Register ``jaxpg/<Id>`` (Gymnasium's physics) and its ``fast_id`` for every task with
    ``gymnasium`` (the imported module), each with Gymnasium's time limit and
    ``reward_threshold``, entry points named as Gymnasium's (``class_name``) and ``kwargs`` as
    Gymnasium's env has them (none; the fast id's ``fidelity``); ids already registered are left
    as they are."""
    for task, (theirs, limit) in COUNTERPARTS.items():
        gym_id = f"jaxpg/{theirs}"
        threshold = gymnasium.spec(theirs).reward_threshold if theirs in gymnasium.registry else None
        variants = {gym_id: {}} if task in NO_FIDELITY else {gym_id: {}, fast_id(gym_id): {"fidelity": "fast"}}
        env_class = class_name(theirs)
        for variant, keywords in variants.items():
            if variant not in gymnasium.registry:
                gymnasium.register(
                    variant,
                    entry_point=f"{API_MODULE}:{env_class}",
                    vector_entry_point=f"{API_MODULE}:{env_class.removesuffix('Env')}VectorEnv",
                    kwargs=keywords,
                    max_episode_steps=limit,
                    reward_threshold=threshold,
                )


class _AfterGymnasiumImport(importlib.abc.MetaPathFinder):
    """Finds ``gymnasium`` through the other finders and has its loader register jaxpg's ids right
    after Gymnasium's own module ran (once: it leaves ``sys.meta_path`` when asked)."""

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        if fullname != "gymnasium":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        run_module = spec.loader.exec_module

        def run_then_register(module: ModuleType) -> None:
            run_module(module)
            try:
                register_ids(module)
            except Exception as error:  # noqa: BLE001 - never break Gymnasium's import
                print(f"warning: jaxpg's Gymnasium ids were not registered: {error}", file=sys.stderr)

        spec.loader.exec_module = run_then_register  # type: ignore[method-assign]
        return spec


def register_when_gymnasium_imports() -> None:
    """Register the ids now if Gymnasium is imported, else right after it is."""
    if "gymnasium" in sys.modules:
        register_ids(sys.modules["gymnasium"])
    elif not any(isinstance(finder, _AfterGymnasiumImport) for finder in sys.meta_path):
        sys.meta_path.insert(0, _AfterGymnasiumImport())


# What the ``.pth`` line runs at start-up: load this file as a module of its own (not through
# ``jaxpg``'s package) and set the hook; silent when jaxpg is gone.
_BOOT = """
try:
    import importlib.util as _jaxpg_util, os as _jaxpg_os
    _jaxpg_spec = _jaxpg_util.find_spec("jaxpg")
    if _jaxpg_spec is not None and _jaxpg_spec.submodule_search_locations:
        _jaxpg_file = _jaxpg_os.path.join(
            list(_jaxpg_spec.submodule_search_locations)[0], "envs", "gymnasium_registration.py"
        )
        _jaxpg_spec = _jaxpg_util.spec_from_file_location("_jaxpg_gymnasium_registration", _jaxpg_file)
        _jaxpg_module = _jaxpg_util.module_from_spec(_jaxpg_spec)
        _jaxpg_spec.loader.exec_module(_jaxpg_module)
        _jaxpg_module.register_when_gymnasium_imports()
except Exception:
    pass
"""


def pth_line() -> str:
    """The one line of ``PTH_NAME``: Python runs a ``.pth`` line that starts with ``import``."""
    return f"import sys; exec({_BOOT!r})\n"


def install(site_dir: Path) -> Path:
    """Write ``PTH_NAME`` into ``site_dir``; returns its path."""
    path = site_dir / PTH_NAME
    path.write_text(pth_line(), encoding="utf-8")
    return path


def main(argv: list[str] | None = None) -> int:
    """``install`` or ``uninstall`` the start-up hook in this interpreter's site-packages (or
    ``--site-dir``); bad usage or an unwritable directory: one ``error:`` line, exit code 2."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m jaxpg.envs.gymnasium_registration",
        description="Register jaxpg's Gymnasium ids in every process of this Python environment.",
    )
    parser.add_argument("action", choices=("install", "uninstall"))
    parser.add_argument("--site-dir", type=Path, default=Path(sysconfig.get_paths()["purelib"]))
    args = parser.parse_args(argv)
    path = args.site_dir / PTH_NAME
    try:
        if args.action == "install":
            install(args.site_dir)
            print(f"installed {path}: gymnasium.make('jaxpg/Hopper-v5') works without importing jaxpg")
        else:
            path.unlink(missing_ok=True)
            print(f"removed {path}")
    except OSError as error:
        print(f"error: cannot write {path}: {error.strerror or error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
