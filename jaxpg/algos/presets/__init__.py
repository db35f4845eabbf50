"""Every algorithm's presets: named ``Config`` overrides keyed by ``(algorithm, preset name)``,
each with the tasks it was made for (or ``None``: any task).

The seam is the task. A preset is made for a task: chosen by runs on it, compared with the other
algorithms' presets for it, re-measured when that task's env changes. So each task's presets, of
every algorithm, live in the task's own module (``hopper``, ``walker2d``, ... ``pong``; the few
made for any task in ``any_task``), each row readable there in full with why it was chosen. The
published settings that presets of several tasks start from (Brax's PPO, Tianshou's and SB3 RL
Zoo's MuJoCo recipes, MinPy's A2C, NPG within 1 M env steps) are in ``recipes``; a setting that one
task's presets use lives in that task's module. A new preset is a row of its task's ``ROWS``; a
new task's presets are a new module added to ``TASK_MODULES``.

``TABLE`` joins the modules' rows, and refuses a key two of them define.
``jaxpg.algos.preset(algo, name, task)`` and ``jaxpg.algos.preset_names(algo, task)`` read it; each
algorithm module's ``PRESETS`` is ``by_algorithm(algo)``, a read-only view of its rows
(``npg.PRESETS["hopper"]``). This package holds plain data and imports no algorithm, so any module
may import it.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType, ModuleType
from typing import Any

from jaxpg.algos.presets import (
    ant,
    any_task,
    cartpole,
    half_cheetah,
    hopper,
    humanoid,
    inverted_pendulum,
    pong,
    pusher,
    reacher,
    swimmer,
    walker2d,
)
from jaxpg.algos.presets.row import Preset

__all__ = ["TABLE", "TASK_MODULES", "Preset", "by_algorithm", "join"]

# The modules whose ``ROWS`` make up the table, in the table's order.
TASK_MODULES: tuple[ModuleType, ...] = (
    inverted_pendulum,
    cartpole,
    hopper,
    walker2d,
    half_cheetah,
    ant,
    humanoid,
    swimmer,
    reacher,
    pusher,
    pong,
    any_task,
)


def join(modules: tuple[ModuleType, ...]) -> Mapping[tuple[str, str], Preset]:
    """The read-only table of every module's ``ROWS``; ``ValueError`` naming both modules when two
    define the same ``(algorithm, preset name)``."""
    table: dict[tuple[str, str], Preset] = {}
    home: dict[tuple[str, str], str] = {}
    for module in modules:
        for key, row in module.ROWS.items():
            if key in table:
                raise ValueError(f"preset {key} is defined in both {home[key]} and {module.__name__}")
            table[key] = row
            home[key] = module.__name__
    return MappingProxyType(table)


TABLE: Mapping[tuple[str, str], Preset] = join(TASK_MODULES)


def by_algorithm(algo: str) -> Mapping[str, Mapping[str, Any]]:
    """Read-only ``{preset name: overrides}`` of ``algo``'s rows, in table order (an algorithm
    module's ``PRESETS``; empty for an algorithm without presets)."""
    return MappingProxyType({name: row.overrides for (a, name), row in TABLE.items() if a == algo})
