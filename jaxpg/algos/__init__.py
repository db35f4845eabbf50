"""Policy-gradient algorithms. Each algorithm module defines ``Config``, ``init(key, env, config)``
and ``update(train_state) -> (train_state, metrics)``, built on the algorithm core
(``jaxpg.algos.core``) and at most one module its family shares (``natural_gradient``: NPG and
TRPO; ``actor_critic``: PPO and A2C).

Presets (named ``Config`` overrides) live in one table, ``presets.TABLE``, keyed by
``(algorithm, preset name)``; each row names the tasks it was made for (``npg``'s ``hopper``:
``("hopper",)``) or none (``a2c``'s ``minpy``: any task). ``preset(algo, name, task)`` is the one
lookup, and it refuses a preset on a task it was not made for, in one line; an algorithm module's
``PRESETS`` is a read-only view of its rows (``npg.PRESETS["hopper"]``).
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

from jaxpg.algos import presets

# name -> module, imported on first use.
ALGORITHMS: dict[str, str] = {
    "npg": "jaxpg.algos.npg",
    "trpo": "jaxpg.algos.trpo",
    "reinforce": "jaxpg.algos.reinforce",
    "reinforce_points": "jaxpg.algos.reinforce_points",
    "vpg": "jaxpg.algos.vpg",
    "a2c": "jaxpg.algos.a2c",
    "ppo": "jaxpg.algos.ppo",
}


def _check_known(name: str) -> None:
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {name!r}; known algorithms: {', '.join(sorted(ALGORITHMS))}")


def get(name: str) -> ModuleType:
    """The algorithm module ``name``; ``ValueError`` listing the known ones otherwise."""
    _check_known(name)
    return importlib.import_module(ALGORITHMS[name])


def preset(algo: str, name: str, task: str | None = None) -> dict[str, Any]:
    """The ``Config`` overrides that algorithm ``algo`` calls ``name`` (``presets.TABLE``), checked
    against ``task`` when given; ``ValueError`` (one line) for an unknown algorithm or preset, or a
    task the preset was not made for."""
    _check_known(algo)
    row = presets.TABLE.get((algo, name))
    if row is None:
        known = ", ".join(preset_names(algo)) or "none"
        others = sorted(a for (a, n) in presets.TABLE if n == name)
        hint = f" ({name!r} is a preset of {' and '.join(others)}: --algo {others[0]})" if others else ""
        raise ValueError(f"unknown preset {name!r} for {algo}{hint}; known presets: {known}")
    if task is not None and not row.suits(task):
        raise ValueError(f"{algo}'s preset {name!r} was made for {', '.join(row.tasks)}, not {task}")
    return dict(row.overrides)


def preset_iterations(algo: str, name: str) -> int | None:
    """How many iterations a run of ``algo``'s preset ``name`` takes by default on the command line
    (``None``: the command's own default; also for an unknown preset, which ``preset`` refuses)."""
    row = presets.TABLE.get((algo, name))
    return None if row is None else row.iterations


def preset_env_kwargs(algo: str, name: str) -> dict[str, Any]:
    """The task options (``jaxpg.envs.make`` keyword arguments) that ``algo``'s preset ``name``
    sets; ``{}`` for most presets, and for an unknown one (which ``preset`` refuses)."""
    row = presets.TABLE.get((algo, name))
    return {} if row is None else dict(row.env_kwargs)


def preset_names(algo: str, task: str | None = None) -> list[str]:
    """The presets of ``algo`` (those that suit ``task`` when given), sorted."""
    _check_known(algo)
    return sorted(n for (a, n), row in presets.TABLE.items() if a == algo and (task is None or row.suits(task)))
