"""The repository's scripts (``experiments/*.py``, ``benchmarks/*.py``) loaded as modules, for tests.

The scripts are not a package: a test loads one by its path from the repository root."""

from __future__ import annotations

import importlib.util
import os
import sys
import types
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def load_script(script: str) -> types.ModuleType:
    """``script`` (a path from the repository root, e.g. ``"benchmarks/pong.py"``) run as a fresh
    module named after its path (``benchmarks_pong``), so that ``experiments/pong.py`` and
    ``benchmarks/pong.py`` stay apart."""
    directory = str((ROOT / script).parent)
    if directory not in sys.path:  # as ``python benchmarks/x.py`` runs it: its siblings (harness.py) importable
        sys.path.insert(0, directory)
    spec = importlib.util.spec_from_file_location(script.replace("/", "_").removesuffix(".py"), ROOT / script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def python_path() -> str:
    """``PYTHONPATH`` for a test's subprocess: the repository first (the jaxpg under test), then the
    path this process was given (where an install put its packages there, as on a machine without
    pip's site-packages for them)."""
    return os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
