"""Sizes that cannot fit: a lower bound of the memory a run needs against the memory there is."""

from __future__ import annotations

import os
from typing import Any

import jax

from jaxpg.algos import core
from jaxpg.run.command.flags import UsageError


def _format_bytes(count: float) -> str:
    """``count`` bytes in binary units: ``'1.5 GiB'``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if count < 1024 or unit == "PiB":
            return f"{count:.0f} {unit}" if unit == "B" else f"{count:.1f} {unit}"
        count /= 1024
    raise AssertionError("unreachable")


def _host_available_bytes() -> int | None:
    """Memory the host can give a process now (``MemAvailable`` of ``/proc/meminfo``, else the
    free physical pages); ``None`` where neither is known."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, AttributeError):
        return None


def available_memory() -> tuple[int, str, bool] | None:
    """``(bytes, where, shared)``: the free memory of the smallest local accelerator (its
    allocator's limit minus what is in use; ``shared`` False: each device holds its own share),
    or on CPU the host's available memory (``shared`` True: every CPU device draws on it);
    ``None`` when the platform does not say."""
    devices = jax.local_devices()
    if devices[0].platform == "cpu":
        host = _host_available_bytes()
        return None if host is None else (host, "this host", True)
    free = []
    for device in devices:
        stats = device.memory_stats() or {}
        if "bytes_limit" not in stats:
            return None
        free.append(int(stats["bytes_limit"]) - int(stats.get("bytes_in_use", 0)))
    return min(free), f"each {devices[0].device_kind}", False


def check_memory(config: Any, env: Any, num_seeds: int, shares: int) -> None:
    """``UsageError`` (one line: how much is needed, how much there is, what to lower) when the
    ``core.memory_lower_bound`` of the config for ``num_seeds`` seeds, its batch split over ``shares``
    devices, exceeds the memory available (``available_memory``), so that an absurd size is
    refused up front instead of hanging in an allocation."""
    memory = available_memory()
    if memory is None:
        return
    available, where, shared = memory
    bound = core.memory_lower_bound(config, env)
    batch = bound["rollout"] + bound["env_states"]
    if shared:  # every device's share, and a copy of the parameters per device, in one memory
        need = num_seeds * (bound["parameters"] * shares + batch)
    else:
        need = num_seeds * (bound["parameters"] + -(-batch // shares))
    if need <= available:
        return
    seeds = f" for {num_seeds} seeds" if num_seeds > 1 else ""
    raise UsageError(
        f"this configuration needs at least {_format_bytes(need)} of memory{seeds} (parameters "
        f"{_format_bytes(bound['parameters'])}, rollout of {config.num_envs} envs x {config.horizon} steps "
        f"{_format_bytes(bound['rollout'])}, env states {_format_bytes(bound['env_states'])}) but {where} has "
        f"{_format_bytes(available)} available; lower --num-envs, --horizon or the network sizes"
    )
