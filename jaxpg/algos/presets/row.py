"""One row of the preset table: a ``Preset``, plain read-only data."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any


@dataclasses.dataclass(frozen=True)
class Preset:
    """One row of the table: ``overrides`` (``Config`` field -> value), the ``tasks`` they were
    made for (``None``: any task), the ``iterations`` a run of the preset takes by default on
    the command line (``None``: the command's own default) and the task options it sets
    (``env_kwargs``, keyword arguments of ``jaxpg.envs.make`` with Gymnasium's meaning, which the
    Gymnasium replay passes on too; besides them the policy's ``action_scaling`` and the physics
    ``fidelity`` it was chosen in, which the command line's flags override)."""

    overrides: Mapping[str, Any]
    tasks: tuple[str, ...] | None = None
    iterations: int | None = None
    env_kwargs: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "overrides", MappingProxyType(dict(self.overrides)))
        object.__setattr__(self, "env_kwargs", MappingProxyType(dict(self.env_kwargs)))

    def suits(self, task: str) -> bool:
        """Whether the preset was made for ``task`` (every task, when it names none)."""
        return self.tasks is None or task in self.tasks


Rows = Mapping[tuple[str, str], Preset]
