"""Values read from JSON or the command line as the types of a config's fields: ``coerce`` checks
and converts one value (``config_io`` reads ``config.json`` with it, ``task_options`` a task's
options)."""

from __future__ import annotations

import math
import types
import typing
from typing import Any


def strip_optional(tp: Any) -> tuple[Any, bool]:
    """``(T, True)`` for ``T | None``, else ``(tp, False)``."""
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1:
            return args[0], True
    return tp, False


def _describe(tp: Any) -> str:
    """What a value of the field type ``tp`` is, in words (for messages)."""
    tp, optional = strip_optional(tp)
    origin = typing.get_origin(tp) or tp
    if origin in (tuple, list):
        args = [a for a in typing.get_args(tp) if a is not Ellipsis]
        plural = {int: "integers", float: "numbers", str: "strings"}.get(args[0] if args else None)
        text = f"a list of {plural}" if plural else "a list"
    else:
        names = {int: "an integer", float: "a number", str: "a string", bool: "true or false", dict: "an object"}
        text = names.get(origin, getattr(tp, "__name__", str(tp)))
    return text + (" or null" if optional else "")


def coerce(tp: Any, value: Any) -> Any:
    """``value`` (e.g. from JSON, where tuples are lists) as the field type ``tp``; ``ValueError``
    (``"must be an integer, got 'abc'"``) when it is not of that type: an integer for ``int``
    (a float only when whole), a number for ``float``, ``true``/``false`` for ``bool``, a list for
    tuples and lists, an object for ``dict``, one of the values of a ``Literal``."""
    base, optional = strip_optional(tp)
    if value is None:
        if optional or base is Any:
            return None
        raise ValueError(f"must be {_describe(tp)}, got null")
    origin = typing.get_origin(base) or base
    wrong = ValueError(f"must be {_describe(tp)}, got {value!r}")
    if origin in (tuple, list):
        if not isinstance(value, (list, tuple)):
            raise wrong
        args = [a for a in typing.get_args(base) if a is not Ellipsis]
        try:
            items = [coerce(args[0], v) for v in value] if args else list(value)
        except ValueError:
            raise wrong from None
        return tuple(items) if origin is tuple else items
    if origin is typing.Literal:
        if value not in typing.get_args(base):
            raise ValueError(f"must be one of {', '.join(map(repr, typing.get_args(base)))}, got {value!r}")
        return value
    if base is bool:
        if isinstance(value, bool) or (isinstance(value, int) and value in (0, 1)):
            return bool(value)
        raise wrong
    if base is int:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise wrong
        if isinstance(value, float) and not (math.isfinite(value) and value.is_integer()):
            raise wrong
        return int(value)
    if base is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise wrong
        return float(value)
    if base is str or origin is dict:
        if not isinstance(value, origin):
            raise wrong
        return value
    return value
