"""Several processes (one per host, or per GPU) joining through ``jax.distributed.initialize``.

``initialize(DistributedConfig.resolve(...))`` reads the coordinator address, the number of
processes and this process's id from flags or from ``JAX_COORDINATOR_ADDRESS``,
``JAX_NUM_PROCESSES`` and ``JAX_PROCESS_ID``, checks that the coordinator can be reached within the
time-out (JAX itself aborts the process when it cannot, after a C++ stack trace) and turns the CPU
collectives on (gloo) where JAX needs them. After it, ``jax.devices()`` lists the devices of all
processes (``jaxpg.mesh`` spans them); only the primary process (``is_primary``) writes files.
"""

from __future__ import annotations

import dataclasses
import os
import socket
import time
from collections.abc import Mapping

import jax
from jax.experimental import multihost_utils


class DistributedError(ValueError):
    """Bad distributed settings or an unreachable coordinator; the message is one line."""


@dataclasses.dataclass(frozen=True)
class DistributedConfig:
    """How this process joins the others.

    Attributes:
      coordinator_address: ``host:port`` of process 0, which runs JAX's coordination service there.
      num_processes: how many processes train together (one launch command each).
      process_id: this process's index, ``0 .. num_processes - 1``.
      timeout_s: seconds to wait for the coordinator (and, on process 0, for the others); also how
        long a process that ends waits for the others at exit before JAX gives up on them.
    """

    coordinator_address: str
    num_processes: int
    process_id: int
    timeout_s: int = 60

    @classmethod
    def resolve(
        cls,
        coordinator_address: str | None = None,
        num_processes: int | None = None,
        process_id: int | None = None,
        timeout_s: int = 60,
        environ: Mapping[str, str] | None = None,
    ) -> DistributedConfig | None:
        """The settings from flags, each falling back to its environment variable
        (``JAX_COORDINATOR_ADDRESS``, ``JAX_NUM_PROCESSES``, ``JAX_PROCESS_ID``); ``None`` for a
        single process (none of them given). Raises ``DistributedError`` for incomplete or
        inconsistent settings."""
        environ = os.environ if environ is None else environ
        address = coordinator_address or environ.get("JAX_COORDINATOR_ADDRESS") or None
        count = num_processes if num_processes is not None else _env_int(environ, "JAX_NUM_PROCESSES")
        index = process_id if process_id is not None else _env_int(environ, "JAX_PROCESS_ID")
        if address is None and count is None and index is None:
            return None
        if count is not None and count == 1 and index in (None, 0):
            return None
        missing = [
            name
            for name, value in (
                ("--coordinator-address (or JAX_COORDINATOR_ADDRESS)", address),
                ("--num-processes (or JAX_NUM_PROCESSES)", count),
                ("--process-id (or JAX_PROCESS_ID)", index),
            )
            if value is None
        ]
        if missing:
            raise DistributedError(f"several processes need {', '.join(missing)} as well")
        host, _, port = address.rpartition(":")
        if not host or not port.isdigit():
            raise DistributedError(f"coordinator address must be host:port, got {address!r}")
        if count < 1 or not 0 <= index < count:
            raise DistributedError(f"process id must be in 0..{count - 1} for {count} processes, got {index}")
        if timeout_s < 1:
            raise DistributedError(f"the distributed time-out must be >= 1 s, got {timeout_s}")
        return cls(coordinator_address=address, num_processes=count, process_id=index, timeout_s=timeout_s)

    @property
    def host_port(self) -> tuple[str, int]:
        host, _, port = self.coordinator_address.rpartition(":")
        return host.strip("[]"), int(port)


def _env_int(environ: Mapping[str, str], name: str) -> int | None:
    text = environ.get(name)
    if text is None or text == "":
        return None
    try:
        return int(text)
    except ValueError:
        raise DistributedError(f"{name} must be an integer, got {text!r}") from None


def wait_for_coordinator(host: str, port: int, timeout_s: float, interval_s: float = 0.2) -> None:
    """Return once ``host:port`` accepts a TCP connection; ``DistributedError`` after ``timeout_s``.

    JAX's own client aborts the whole process (a C++ check failure) when the coordinator stays
    unreachable, so the other processes check first, in Python, and fail with one line.
    """
    deadline = time.monotonic() + timeout_s
    last: OSError | None = None
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            reason = f" ({last.strerror or last})" if last is not None else ""
            raise DistributedError(
                f"cannot reach the coordinator at {host}:{port} within {timeout_s:g} s{reason}; "
                "is process 0 running with the same --coordinator-address?"
            )
        try:
            with socket.create_connection((host, port), timeout=max(min(remaining, 1.0), 0.01)):
                return
        except OSError as e:
            last = e
            time.sleep(min(interval_s, max(deadline - time.monotonic(), 0.0)))


def _enable_cpu_collectives() -> None:
    """Cross-process collectives on the CPU need an implementation (gloo); the default of some
    JAX versions is none. Harmless on GPUs, which use NCCL."""
    try:
        if jax.config.jax_cpu_collectives_implementation in (None, "", "none"):
            jax.config.update("jax_cpu_collectives_implementation", "gloo")
    except AttributeError:  # a JAX without the option has its CPU collectives on
        pass


def initialize(config: DistributedConfig) -> None:
    """Join the ``config.num_processes`` processes through ``jax.distributed.initialize``.

    Must run before anything else touches JAX's backends (devices, arrays, compilation). A
    process other than 0 first waits up to ``config.timeout_s`` for the coordinator to accept
    connections and raises ``DistributedError`` (one line) if it never does; process 0 waits up
    to the same time for the others (then JAX aborts it with ``DEADLINE_EXCEEDED``).
    """
    if config.process_id != 0:
        wait_for_coordinator(*config.host_port, timeout_s=config.timeout_s)
    _enable_cpu_collectives()
    try:
        jax.distributed.initialize(
            coordinator_address=config.coordinator_address,
            num_processes=config.num_processes,
            process_id=config.process_id,
            initialization_timeout=config.timeout_s,
            # A process that failed waits this long at exit for the others before JAX aborts them.
            shutdown_timeout_seconds=config.timeout_s,
        )
    except Exception as e:  # noqa: BLE001 - any failure to join is reported as one line
        first = (str(e).strip().splitlines() or [type(e).__name__])[0]
        raise DistributedError(
            f"process {config.process_id} could not join {config.coordinator_address}: {first}"
        ) from None


def is_primary() -> bool:
    """This process writes the run's files (process 0; always true with one process)."""
    return jax.process_index() == 0


def barrier(name: str) -> None:
    """Wait until every process reached ``barrier(name)`` (nothing to do with one process)."""
    if jax.process_count() > 1:
        multihost_utils.sync_global_devices(name)
