"""A task's own options (Gymnasium's keyword arguments of its env, such as Ant's
``include_cfrc_ext_in_observation``) given on the command line as ``--env-kwargs KEY=VALUE ...``
or by a preset: parsed, checked against the task's constructor and converted to its types.

The simulation settings that have their own flags (``--fidelity``, ``--impl``,
``--max-episode-steps``), ``--action-scaling`` (an env wrapper, which a preset may also set) and
the physics backend's buffer sizes are not task options."""

from __future__ import annotations

import inspect
import json
import typing
from typing import Any

from jaxpg import envs
from jaxpg.run.rundir import coercion

# Parameters of a task's constructor that are simulation settings, not task options: those with
# their own flags, then MuJoCo Warp's buffer sizes (which some tasks raise by default).
SIMULATION_SETTINGS = ("self", "fidelity", "impl", "max_episode_steps")
BUFFER_SIZES = ("naconmax", "njmax")
# ``jaxpg.envs.make``'s own keyword arguments that a preset's ``env_kwargs`` may set beside the
# task options (each has its own flag).
WRAPPER_SETTINGS = ("action_scaling",)
# The simulation settings that a preset's ``env_kwargs`` may set too (the physics it was chosen
# in); the flag, where given, wins.
PRESET_SIMULATION_SETTINGS = ("fidelity",)
# What a preset's ``env_kwargs`` may hold that is not a task option.
PRESET_ENV_SETTINGS = WRAPPER_SETTINGS + PRESET_SIMULATION_SETTINGS


def parse_assignment(text: str) -> tuple[str, Any]:
    """``"KEY=VALUE"`` -> ``(key, value)``, the value read as JSON when it is JSON (``false``,
    ``0.3``, ``[0.2, 1.0]``; ``True``/``False``/``None`` too), else kept as text. ``ValueError``
    without ``=`` or with an empty key."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValueError(f"expected KEY=VALUE, got {text!r}")
    raw = raw.strip()
    python_words = {"True": "true", "False": "false", "None": "null"}
    try:
        value = json.loads(python_words.get(raw, raw))
    except json.JSONDecodeError:
        value = raw
    return key, value


def option_types(task: str) -> dict[str, Any]:
    """Name -> type of each option of ``task``'s constructor (``jaxpg.envs.task_class``), in
    order; ``ValueError`` for an unknown task."""
    return _constructor_options(envs.task_class(task))


def _constructor_options(cls: type) -> dict[str, Any]:
    """Name -> type of each named parameter of ``cls``'s constructor, and, where its ``**kwargs``
    construct another class (``cls.OPTIONS_FORWARDED_TO``), that class's too."""
    hints = typing.get_type_hints(cls.__init__)
    out: dict[str, Any] = {}
    for name, param in inspect.signature(cls.__init__).parameters.items():
        if param.kind == param.VAR_KEYWORD and getattr(cls, "OPTIONS_FORWARDED_TO", None) is not None:
            out.update({k: v for k, v in _constructor_options(cls.OPTIONS_FORWARDED_TO).items() if k not in out})
        if name in SIMULATION_SETTINGS + BUFFER_SIZES or param.kind in (param.VAR_KEYWORD, param.VAR_POSITIONAL):
            continue
        out[name] = hints.get(name, Any)
    return out


def check_options(task: str, options: dict[str, Any]) -> dict[str, Any]:
    """``options`` converted to the types of ``task``'s constructor (lists to tuples, ``0``/``1``
    to booleans); ``ValueError`` (one line) naming the option for an unknown name or a value of
    the wrong type, listing the task's options."""
    if not options:
        return {}
    types = option_types(task)
    out: dict[str, Any] = {}
    for name, value in options.items():
        if name in SIMULATION_SETTINGS[1:] + WRAPPER_SETTINGS:
            flag = "--" + name.replace("_", "-")
            raise ValueError(f"{name} is set by its own flag, not --env-kwargs: use {flag}")
        if name not in types:
            known = ", ".join(types) or "none"
            raise ValueError(f"task {task!r} has no option {name!r}; its options: {known}")
        try:
            out[name] = coercion.coerce(types[name], value)
        except ValueError as e:
            raise ValueError(f"task option {name} {e}") from None
    return out
