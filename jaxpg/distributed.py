"""Several devices and several processes, through JAX's own machinery.

The env batch is the one axis jaxpg splits: a 1-D device ``Mesh`` with the axis ``"envs"``
(``ENV_AXIS``) spans every device of every process, and ``jaxpg.algos.core.sample`` /
``evaluate`` step each device's own slice of the envs under ``jax.shard_map``. The sampler learns
about the mesh from JAX's mesh context (``jax.sharding.get_abstract_mesh()``), which
``on_mesh(update, mesh)`` sets while ``update`` is traced (``jax.set_mesh(mesh)`` around a call
works as well); with no mesh in context, or one without the ``"envs"`` axis, sampling runs on one
device as it always did. The learning side stays under jit's automatic partitioning (GSPMD),
which makes every reduction over the batch global.

Several processes (one per host, or per GPU) join through ``jax.distributed.initialize``:
``initialize(DistributedConfig.resolve(...))`` reads the coordinator address, the number of
processes and this process's id from flags or from ``JAX_COORDINATOR_ADDRESS``,
``JAX_NUM_PROCESSES`` and ``JAX_PROCESS_ID``, checks that the coordinator can be reached within the
time-out (JAX itself aborts the process when it cannot, after a C++ stack trace) and turns the CPU
collectives on (gloo) where JAX needs them. After it, ``jax.devices()`` lists the devices of all
processes; arrays are placed on the global mesh from identical host values (``put_global``) and
fetched back with ``host_copy``; only the primary process (``is_primary``) writes files.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import socket
import time
from collections.abc import Callable, Mapping
from typing import Any

import jax
import numpy as np
from jax.sharding import AbstractMesh, AxisType, Mesh, NamedSharding, PartitionSpec

ENV_AXIS = "envs"


class DistributedError(ValueError):
    """Bad distributed settings or an unreachable coordinator; the message is one line."""


# --------------------------------------------------------------------------- the env mesh


def env_mesh(devices: Any = None) -> Mesh:
    """A 1-D mesh with the axis ``ENV_AXIS`` over ``devices`` (default: ``jax.devices()``, i.e.
    every device of every process). Its axis is ``Auto``: outside ``shard_map`` jit partitions."""
    devices = jax.devices() if devices is None else list(devices)
    if len(devices) > 1:
        use_gspmd_partitioner()
    return Mesh(np.array(devices), (ENV_AXIS,), axis_types=(AxisType.Auto,))


def use_gspmd_partitioner() -> None:
    """Partition sharded programs with GSPMD instead of Shardy (JAX's default since 0.7).

    With JAX 0.11.2 on GPUs, XLA's compiler crashed (segmentation fault in the ``shardy-xla`` pass)
    on jaxpg's rollout under ``shard_map`` over 2 H200s, with both MJX implementations; with GSPMD
    the same program compiles and scales (BENCHMARKS.md, 2026-11-22). A multi-device ``env_mesh``
    calls this, on every backend, so that the CPU tests run the partitioner the GPUs use.
    """
    if getattr(jax.config, "jax_use_shardy_partitioner", False):
        jax.config.update("jax_use_shardy_partitioner", False)


def context_env_shards() -> int:
    """How many slices the env batch is split into by the mesh in context (1: none).

    Read while tracing: the abstract mesh that ``on_mesh`` or ``jax.set_mesh`` put in context, if
    it has the ``ENV_AXIS`` axis.
    """
    mesh = jax.sharding.get_abstract_mesh()
    if mesh.empty or ENV_AXIS not in mesh.axis_names:
        return 1
    return int(mesh.shape[ENV_AXIS])


def check_divisible(num_envs: int, shards: int, what: str = "num_envs") -> None:
    """``ValueError`` (one line) unless ``num_envs`` splits evenly over ``shards`` devices."""
    if num_envs % shards:
        raise ValueError(
            f"{what} {num_envs} is not divisible by the {shards} devices the env batch is split over "
            "(use a multiple of the device count)"
        )


@functools.lru_cache(maxsize=64)
def on_mesh(update: Callable[..., Any], mesh: Mesh | AbstractMesh) -> Callable[..., Any]:
    """``update`` traced with ``mesh`` in context, so that its sampling splits the env batch.

    The result is a plain function (``jit``, ``vmap`` and ``lax.scan`` it like ``update``), cached
    per ``(update, mesh)`` so that ``jaxpg.train``'s compiled blocks are reused. Only the tracing of
    ``update`` sees the mesh: jitted host-side code elsewhere (videos, checkpoints) is unaffected,
    which ``jax.set_mesh`` around the training loop would not guarantee. The state should already
    live on ``mesh`` (``shard_state``).
    """
    abstract = mesh.abstract_mesh if isinstance(mesh, Mesh) else mesh

    @functools.wraps(update)
    def update_on_mesh(*args: Any, **kwargs: Any) -> Any:
        with jax.sharding.use_abstract_mesh(abstract):
            return update(*args, **kwargs)

    return update_on_mesh


def batch_spec(batched: bool, leading: int = 0) -> PartitionSpec:
    """``PartitionSpec`` of an env-state leaf: its env axis (after ``leading`` unsplit axes, e.g.
    the seed axis) on ``ENV_AXIS`` when ``batched``, else replicated."""
    return PartitionSpec(*([None] * leading), ENV_AXIS) if batched else PartitionSpec()


# --------------------------------------------------------------------------- placing and fetching


def put_global(tree: Any, shardings: Any) -> Any:
    """Place ``tree`` (host values, identical on every process) with ``shardings`` (a matching
    tree of ``Sharding``s, which may span several processes). Each process supplies the slices
    its own devices hold (``jax.make_array_from_callback``); with one process this is a
    ``device_put``."""

    def put(x: Any, sharding: jax.sharding.Sharding) -> jax.Array:
        host = np.asarray(x)
        return jax.make_array_from_callback(host.shape, sharding, lambda index: host[index])

    return jax.tree.map(put, host_copy(tree), shardings)


def host_copy(tree: Any) -> Any:
    """NumPy copy of ``tree`` on every process. Arrays split over several processes are
    gathered (a collective: every process must call this with the same tree); replicated and
    local arrays are read locally."""

    def fetch(x: Any) -> np.ndarray:
        if isinstance(x, jax.Array) and not x.is_fully_addressable and not x.is_fully_replicated:
            from jax.experimental import multihost_utils

            return np.asarray(multihost_utils.process_allgather(x, tiled=True))
        return np.asarray(jax.device_get(x))

    return jax.tree.map(fetch, tree)


def replicated(tree: Any, mesh: Mesh) -> Any:
    """``tree`` replicated on every device of ``mesh`` (``put_global`` with ``PartitionSpec()``)."""
    sharding = NamedSharding(mesh, PartitionSpec())
    return put_global(tree, jax.tree.map(lambda _: sharding, tree))


def shard_state(ts: Any, vmap_seeds: bool, mesh: Any = None) -> Any:
    """``ts`` placed on ``mesh`` (default: ``env_mesh()``, every device of every
    process): the env axis of ``ts.env_state`` split over the ``"envs"`` axis (after the seed axis
    with ``vmap_seeds``), everything else replicated, including MuJoCo Warp's per-batch buffers
    (``core.env_batch_mask``). Every process passes the same ``ts``; each places its share."""
    from jaxpg.algos import core  # the algorithms import this module

    mesh = env_mesh() if mesh is None else mesh
    lead = 1 if vmap_seeds else 0
    mask = core.env_batch_mask(core.sampler_env(ts.env, ts.config), ts.env_state, leading=lead)
    shardings = jax.tree.map(lambda batched: NamedSharding(mesh, batch_spec(batched, lead)), mask)
    env_state = put_global(ts.env_state, shardings)
    rest = replicated(ts.replace(env_state=()), mesh)
    return rest.replace(env_state=env_state)


# --------------------------------------------------------------------------- several processes


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
        from jax.experimental import multihost_utils

        multihost_utils.sync_global_devices(name)
