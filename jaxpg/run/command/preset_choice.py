"""The preset a fresh run takes, read from the preset table (``jaxpg.algos.presets``) once into one
value that planning passes around: its ``Config`` overrides, task options and iterations."""

from __future__ import annotations

import dataclasses
from typing import Any

from jaxpg import algos
from jaxpg.run.command.flags import UsageError


@dataclasses.dataclass(frozen=True)
class ResolvedPreset:
    """One preset of one algorithm, as a run takes it; the empty value (``name`` ``None``): none.

    Attributes:
      name: the preset's name (``--preset``), or ``None``.
      config: the ``Config`` overrides it sets.
      env_kwargs: the task options and env settings it sets (``jaxpg.envs.make`` keyword arguments).
      iterations: the iterations a run of it takes by default (``None``: the command's own default).
    """

    name: str | None = None
    config: dict[str, Any] = dataclasses.field(default_factory=dict)
    env_kwargs: dict[str, Any] = dataclasses.field(default_factory=dict)
    iterations: int | None = None


def resolve(algo: str, name: str | None, task: str | None) -> ResolvedPreset:
    """``algo``'s preset ``name`` checked against ``task`` (when given); the empty value for no
    preset. ``UsageError`` (one line) for an unknown preset or one not made for ``task``, naming the
    presets that suit it."""
    if name is None:
        return ResolvedPreset()
    try:
        config = algos.preset(algo, name, task)
    except ValueError as e:
        known = ", ".join(algos.preset_names(algo, task)) or "none"
        raise UsageError(f"{e}; presets of {algo} for {task}: {known}") from None
    return ResolvedPreset(name, config, algos.preset_env_kwargs(algo, name), algos.preset_iterations(algo, name))


def defaults_of(algo: str, name: str | None) -> dict[str, Any]:
    """The ``Config`` overrides of ``algo``'s preset ``name`` before the task is known (the command
    line's defaults, shown by ``--help``); ``{}`` for no preset or an unknown one, which planning
    refuses once it knows the task (``resolve``)."""
    return algos.preset(algo, name) if name in algos.preset_names(algo) else {}
