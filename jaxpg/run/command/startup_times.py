"""Where a command's start-up went, for the end-of-run report's ``start-up:`` line: the seconds
from the process's start to its first training block, split at the points the command passes
(``StartupTimes``)."""

from __future__ import annotations

import dataclasses
import os
import resource
import sys
import time


def seconds_since_process_start() -> float | None:
    """Seconds since this process started, from Linux's ``/proc`` (10 ms resolution); ``None``
    where there is no ``/proc``."""
    try:
        with open("/proc/self/stat") as stat, open("/proc/uptime") as uptime:
            # Fields after the command name, which may hold spaces: the 22nd field (start time,
            # in clock ticks since boot) is the 20th after it.
            start_ticks = int(stat.read().rsplit(")", 1)[1].split()[19])
            since_boot = float(uptime.read().split()[0])
        return max(since_boot - start_ticks / os.sysconf("SC_CLK_TCK"), 0.0)
    except (OSError, ValueError, IndexError):
        return None


def children_cpu_seconds() -> float:
    """CPU seconds of the programs this process ran and waited for (``RUSAGE_CHILDREN``), which
    survive an ``exec``."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


CHILDREN_CPU_AT_IMPORT = children_cpu_seconds()
"""``children_cpu_seconds`` when the command line was imported, before jaxpg ran any program: more
than none when a shell ran commands and then ``exec``-ed Python in its own process (``bash -c 'pip
install -e . && python ...'`` does), whose age then counts those commands (``pip``) as well."""


def mjx_import_span() -> tuple[float, float] | None:
    """``(start, end)``, the ``time.perf_counter()`` readings around this process's ``import
    mujoco.mjx`` (``jaxpg.envs.mjx_env`` takes them), or ``None`` when no MJX task was made."""
    mjx_env = sys.modules.get("jaxpg.envs.mjx_env")
    return getattr(mjx_env, "MJX_IMPORT_SPAN", None)


@dataclasses.dataclass
class StartupTimes:
    """``time.perf_counter()`` readings a command takes on its way to training.

    Attributes:
      before_planning: seconds from the process's start to planning (the interpreter, ``jax``,
        ``jaxpg``, JAX's backend), ``None`` where ``/proc`` cannot tell.
      planning: when planning started.
      planned: when the plan was checked (the env built, MJX imported on the way).
      state_ready: when the initial training state was built.
    """

    before_planning: float | None
    planning: float
    planned: float | None = None
    state_ready: float | None = None

    @classmethod
    def start(cls) -> StartupTimes:
        """The readings of a command that starts planning now. ``before_planning`` only when the
        process was started for it: its ``__main__`` is ``python -m jaxpg.cli`` or a ``.py`` script,
        not an installed tool that calls ``main`` later (pytest, whether through its launcher in the
        environment's ``bin/`` or ``python -m pytest``) or a notebook's kernel, whose age says
        nothing, and it ran no program before (``CHILDREN_CPU_AT_IMPORT``)."""
        entry = sys.modules.get("__main__")
        spec_name = getattr(getattr(entry, "__spec__", None), "name", "") or ""
        path = getattr(entry, "__file__", None) or ""
        installed = any(part in path for part in ("site-packages", "dist-packages"))
        script = path.endswith(".py") and not installed
        # A process that ran other programs before Python (a shell that exec-ed it) is older than the command.
        for_this = (spec_name.startswith("jaxpg.") or script) and CHILDREN_CPU_AT_IMPORT == 0.0
        return cls(before_planning=seconds_since_process_start() if for_this else None, planning=time.perf_counter())

    def report(self, first_block: float) -> str | None:
        """``start-up: T s to the first block: ...`` up to ``first_block`` (a ``perf_counter``
        reading): the seconds before planning (the interpreter, ``jax``, ``jaxpg``, JAX's backend),
        planning with the env (and the MJX import where it happened), the initial state and the
        rest; ``None`` before the plan and the state were ready."""
        if self.planned is None or self.state_ready is None:
            return None
        before = self.before_planning or 0.0
        total = before + first_block - self.planning
        span = mjx_import_span()

        mjx_before = span is not None and span[1] <= self.planning
        mjx_planning = span is not None and self.planning <= span[0] <= self.planned

        def importing_mjx(inside: bool) -> str:  # only called with span set when inside
            return f" ({span[1] - span[0]:.1f} s of it importing mujoco.mjx)" if inside else ""

        parts = []
        if self.before_planning is not None:
            parts.append(f"{before:.1f} s before planning{importing_mjx(mjx_before)}")
        parts.append(f"{self.planned - self.planning:.1f} s planning and building the env{importing_mjx(mjx_planning)}")
        parts.append(f"{self.state_ready - self.planned:.1f} s the initial state")
        parts.append(f"{first_block - self.state_ready:.1f} s the run directory and the rest")
        return f"start-up: {total:.1f} s to the first block: " + ", ".join(parts)
