"""Sweeps of many configurations and seeds in one compiled program, reported with the field's
statistics (docs/sweeps.md).

``jaxpg.sweep(spec, out_dir, ...)`` (this module is callable: ``api.run_sweep``) trains, scores and
reports a ``SweepSpec``; ``python -m jaxpg.sweep`` is its command line. The pieces: ``spec``
(what is swept, checked before anything compiles), ``runner`` (programs, chunks, sharding over
devices), ``scoring`` (Gymnasium scores in CPU workers), ``store`` (the resumable directory),
``stats`` (IQM and stratified-bootstrap intervals, profiles, probability of improvement),
``report`` and ``plots`` (tables and figures).
"""

from __future__ import annotations

import sys
import types
from typing import Any

from jaxpg.sweep.api import run_sweep
from jaxpg.sweep.spec import Configuration, Range, SpecError, SweepSpec

__all__ = ["Configuration", "Range", "SpecError", "SweepSpec", "run_sweep"]


class _CallableModule(types.ModuleType):
    """``jaxpg.sweep(...)`` is ``run_sweep(...)``."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return run_sweep(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
