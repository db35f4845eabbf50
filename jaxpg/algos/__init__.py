"""Policy-gradient algorithms. Each algorithm module defines ``Config``, ``init(key, env, config)``,
``update(train_state) -> (train_state, metrics)`` and ``PRESETS`` (named ``Config`` overrides),
built on the algorithm core (``jaxpg.algos.core``) and at most one module its family shares
(``natural_gradient``: NPG and TRPO; ``actor_critic``: PPO and A2C).

A preset made for particular tasks names them in its module's ``PRESET_TASKS`` (e.g.
``npg.PRESET_TASKS["hopper"] == ("hopper",)``); the others (``a2c``'s ``minpy``) suit any task.
``preset(algo, name, task)`` is the one lookup, and it refuses a preset on a task it was not made
for, in one line.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

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


def get(name: str) -> ModuleType:
    """The algorithm module ``name``; ``ValueError`` listing the known ones otherwise."""
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {name!r}; known algorithms: {', '.join(sorted(ALGORITHMS))}")
    return importlib.import_module(ALGORITHMS[name])


def preset(algo: str, name: str, task: str | None = None) -> dict[str, Any]:
    """The ``Config`` overrides that algorithm ``algo`` calls ``name``, checked against ``task`` when
    given; ``ValueError`` (one line) for an unknown preset or a task it was not made for."""
    module = get(algo)
    presets = getattr(module, "PRESETS", {})
    if name not in presets:
        known = ", ".join(sorted(presets)) or "none"
        raise ValueError(f"unknown preset {name!r} for {algo}; known presets: {known}")
    tasks = getattr(module, "PRESET_TASKS", {}).get(name)
    if task is not None and tasks is not None and task not in tasks:
        raise ValueError(f"{algo}'s preset {name!r} was made for {', '.join(tasks)}, not {task}")
    return dict(presets[name])


def preset_names(algo: str, task: str | None = None) -> list[str]:
    """The presets of ``algo`` (those that suit ``task`` when given), sorted."""
    module = get(algo)
    tasks = getattr(module, "PRESET_TASKS", {})
    return sorted(n for n in getattr(module, "PRESETS", {}) if task is None or task in tasks.get(n, (task,)))
