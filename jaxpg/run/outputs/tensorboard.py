"""TensorBoard event files for a run's scalars and its config text, written by jaxpg itself.

A run's curves need scalars (and the config as text), not a TensorBoard library: this module
writes the event file format directly, so a run never imports tensorboardX, which imports PyTorch
whenever it is installed (seconds of every command's start on such a machine) and flushes on a
thread of its own (which, with MuJoCo Warp, competes for the interpreter with the physics step's
Python callback).

The format: a file ``events.out.tfevents.<time>.<host>.<pid>`` of records, each ``length``
(uint64 little-endian), the masked CRC-32C of those 8 bytes (uint32), the data, and the data's
masked CRC-32C; each record's data is a serialized ``tensorflow.Event`` protocol buffer. The first
event names the format (``file_version: "brain.Event:2"``); scalars are an event whose
``Summary`` holds one ``Value`` (a ``simple_value``) per tag, text one with a string tensor for the
``text`` plugin.
``TensorBoardLog`` is the run's sink of them (``jaxpg.run.outputs.sink``).
``purge_step`` (a resumed run) adds a ``SessionLog`` START event at that step, from which
TensorBoard drops the earlier events of higher steps.

    writer = EventWriter("runs/x/tensorboard/seed_0")
    writer.add_scalar("return_mean_policy", 3310.5, step=120)
    writer.close()
"""

from __future__ import annotations

import functools
import os
import socket
import struct
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg.run.outputs.sink import Block, Entry, Sink
from jaxpg.run.rundir.layout import TENSORBOARD_DIR

FILE_VERSION = "brain.Event:2"


def _crc32c_table() -> tuple[int, ...]:
    """The byte table of CRC-32C (Castagnoli, reflected polynomial 0x82F63B78)."""
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
        table.append(crc)
    return tuple(table)


_TABLE = _crc32c_table()


def crc32c(data: bytes) -> int:
    """CRC-32C of ``data`` (``crc32c(b"123456789") == 0xE3069283``)."""
    crc = 0xFFFFFFFF
    table = _TABLE
    for byte in data:
        crc = table[(crc ^ byte) & 0xFF] ^ (crc >> 8)
    return crc ^ 0xFFFFFFFF


def crc32c_many(datas: Sequence[bytes]) -> np.ndarray:
    """CRC-32C of each of ``datas`` (``[len(datas)]`` uint32), all advanced byte by byte together
    in NumPy: a block of a many-seed run frames hundreds of events, which one at a time in Python
    cost too much host time."""
    lengths = np.array([len(d) for d in datas], np.int64)
    crc = np.full(len(datas), 0xFFFFFFFF, np.uint32)
    if not len(datas) or not lengths.max():
        return crc ^ np.uint32(0xFFFFFFFF)
    width = int(lengths.max())
    data = np.zeros((len(datas), width), np.uint32)
    for row, d in enumerate(datas):
        data[row, : len(d)] = np.frombuffer(d, np.uint8)
    table = np.asarray(_TABLE, np.uint32)
    # Rows sorted by length, longest first: at byte p only the rows longer than p advance, a prefix.
    order = np.argsort(-lengths, kind="stable")
    data, lengths, crc = data[order], lengths[order], crc[order]
    active = len(datas)
    for p in range(width):
        while lengths[active - 1] <= p:
            active -= 1
        state = crc[:active]
        crc[:active] = table[(state ^ data[:active, p]) & 0xFF] ^ (state >> 8)
    out = np.empty_like(crc)
    out[order] = crc ^ np.uint32(0xFFFFFFFF)
    return out


def masked_crc32c(data: bytes) -> int:
    """The record format's checksum: CRC-32C rotated right by 15 bits plus 0xA282EAD8 (mod 2**32)."""
    crc = crc32c(data)
    return (((crc >> 15) | (crc << 17)) + 0xA282EAD8) & 0xFFFFFFFF


def record(data: bytes) -> bytes:
    """``data`` framed as one record (length, its checksum, data, its checksum)."""
    length = struct.pack("<Q", len(data))
    return length + struct.pack("<I", masked_crc32c(length)) + data + struct.pack("<I", masked_crc32c(data))


def _mask(crc: np.ndarray) -> np.ndarray:
    """``masked_crc32c``'s rotation and offset, on an array of CRCs."""
    crc = crc.astype(np.uint64)
    return ((((crc >> 15) | (crc << 17)) + 0xA282EAD8) & 0xFFFFFFFF).astype(np.uint32)


def records(datas: Sequence[bytes]) -> list[bytes]:
    """Each of ``datas`` framed as ``record`` frames it, the checksums computed together."""
    lengths = [struct.pack("<Q", len(d)) for d in datas]
    sums = _mask(crc32c_many([*lengths, *datas]))
    n = len(datas)
    return [lengths[i] + struct.pack("<I", sums[i]) + datas[i] + struct.pack("<I", sums[n + i]) for i in range(n)]


# Protocol-buffer encoding, the few field kinds an event needs (wire types 0, 1, 2 and 5).


def _varint(value: int) -> bytes:
    value &= (1 << 64) - 1  # a negative int64 is its 64-bit two's complement
    out = bytearray()
    while True:
        low = value & 0x7F
        value >>= 7
        if value:
            out.append(low | 0x80)
        else:
            out.append(low)
            return bytes(out)


def _int_field(number: int, value: int) -> bytes:
    return _varint(number << 3) + _varint(value) if value else b""


def _double_field(number: int, value: float) -> bytes:
    return _varint(number << 3 | 1) + struct.pack("<d", value) if value else b""


def _bytes_field(number: int, value: bytes) -> bytes:
    return _varint(number << 3 | 2) + _varint(len(value)) + value


def event(
    wall_time: float, step: int, *, file_version: str = "", summary: bytes = b"", session_start: bool = False
) -> bytes:
    """A serialized ``Event``: ``wall_time`` (field 1), ``step`` (2), then one of ``file_version``
    (3), a serialized ``summary`` (5) or a ``SessionLog`` with status START (7)."""
    out = _double_field(1, wall_time) + _int_field(2, step)
    if file_version:
        out += _bytes_field(3, file_version.encode())
    if summary:
        out += _bytes_field(5, summary)
    if session_start:
        out += _bytes_field(7, _int_field(1, 1))  # SessionLog.status = START
    return out


@functools.lru_cache(maxsize=1024)
def _value_prefix(tag: str) -> bytes:
    """The bytes of a scalar ``Value`` of ``tag`` before its float: the ``Value`` field's key and
    length, the tag (field 1), the ``simple_value`` key (field 2, wire type 5)."""
    tag_field = _bytes_field(1, tag.encode())
    return _varint(1 << 3 | 2) + _varint(len(tag_field) + 5) + tag_field + _varint(2 << 3 | 5)


def scalar_summary(tag: str, value: float) -> bytes:
    """A serialized ``Summary`` of one value: ``tag`` (field 1 of ``Value``), ``simple_value`` (2)."""
    return scalars_summary({tag: value})


def scalars_summary(values: Mapping[str, float]) -> bytes:
    """A serialized ``Summary`` of several scalars, one ``Value`` each in the order given (what
    TensorFlow's merged summaries wrote: TensorBoard reads every ``Value`` of an event as its own
    tag's point at the event's step)."""
    return b"".join(_value_prefix(tag) + struct.pack("<f", value) for tag, value in values.items())


def text_summary(tag: str, text: str) -> bytes:
    """A serialized ``Summary`` of ``text`` for TensorBoard's text plugin: a ``Value`` tagged
    ``<tag>/text_summary`` with ``metadata.plugin_data.plugin_name = "text"`` (field 9) and a
    string tensor of shape [1] (field 8: ``dtype`` DT_STRING = 7, ``tensor_shape``, ``string_val``)."""
    metadata = _bytes_field(1, _bytes_field(1, b"text"))
    shape = _bytes_field(2, _int_field(1, 1))
    tensor = _int_field(1, 7) + _bytes_field(2, shape) + _bytes_field(8, text.encode())
    value = _bytes_field(1, f"{tag}/text_summary".encode()) + _bytes_field(8, tensor) + _bytes_field(9, metadata)
    return _bytes_field(1, value)


class EventWriter:
    """One event file in ``logdir`` (created if missing), written through a buffered file:
    ``flush`` hands it to the operating system, ``close`` ends it.

    ``purge_step``: a resumed run's first new step; TensorBoard then hides what an earlier
    process wrote for that step and later ones."""

    def __init__(self, logdir: str | os.PathLike, purge_step: int | None = None) -> None:
        self.logdir = Path(logdir)
        self.logdir.mkdir(parents=True, exist_ok=True)
        now = time.time()
        name = f"events.out.tfevents.{int(now):010d}.{socket.gethostname()}.{os.getpid()}"
        self.path = self.logdir / name
        for n in range(1, 1000):  # a second writer in the same second of the same process gets a file of its own
            if not self.path.exists():
                break
            self.path = self.logdir / f"{name}.{n}"
        self._file = self.path.open("xb")
        self._file.write(record(event(now, purge_step or 0, file_version=FILE_VERSION)))
        if purge_step is not None:
            self._file.write(record(event(now, purge_step, session_start=True)))
        self._file.flush()

    def add_scalar(self, tag: str, value: float, step: int) -> None:
        self._file.write(record(event(time.time(), step, summary=scalar_summary(tag, value))))

    def write_records(self, framed: Sequence[bytes]) -> None:
        """Append records framed already (``records``)."""
        self._file.write(b"".join(framed))

    def add_text(self, tag: str, text: str, step: int = 0) -> None:
        self._file.write(record(event(time.time(), step, summary=text_summary(tag, text))))

    def flush(self) -> None:
        self._file.flush()

    def close(self) -> None:
        self._file.close()


class TensorBoardLog(Sink):
    """The sink of TensorBoard: each block's scalars in event files (``EventWriter``), one
    sub-directory per seed (``tensorboard/seed_<s>``), keyed by the metric name against the
    iteration; a metric not measured (``null`` in the record) is skipped. ``start_iteration`` > 0
    (a resumed run) purges the events the interrupted run wrote after that iteration."""

    entries = (
        Entry(
            TENSORBOARD_DIR,
            directory=True,
            inside=(rf"{TENSORBOARD_DIR}/seed_\d+", rf"{TENSORBOARD_DIR}/seed_\d+/events\.out\.tfevents\.[^/]+"),
        ),
    )

    def __init__(self, run_dir: str | os.PathLike, seeds: Sequence[int], start_iteration: int = 0):
        purge = start_iteration + 1 if start_iteration > 0 else None
        self._writers = {
            seed: EventWriter(Path(run_dir) / TENSORBOARD_DIR / f"seed_{seed}", purge_step=purge) for seed in seeds
        }

    @classmethod
    def open(cls, plan: Any, printer: Any) -> TensorBoardLog:
        return cls(plan.run_dir, plan.run.seeds, start_iteration=plan.start)

    def write_block(self, block: Block) -> None:
        self.write(block.records)

    def write(self, rows: Sequence[dict[str, Any]]) -> None:
        """One event per record (``metrics_log.block_records``) holding its scalars, the events of
        all seeds framed together (``records``)."""
        seeds, events, now = [], [], time.time()
        for row in rows:
            if row["seed"] not in self._writers:
                continue
            # A non-finite value ("nan", "inf" in the record) is a float for TensorBoard.
            scalars = {k: float(v) for k, v in row.items() if k not in ("iteration", "seed") and v is not None}
            seeds.append(row["seed"])
            events.append(event(now, row["iteration"], summary=scalars_summary(scalars)))
        for seed, framed in zip(seeds, records(events), strict=True):
            self._writers[seed].write_records([framed])
        for writer in self._writers.values():
            writer.flush()

    def add_text(self, tag: str, text: str) -> None:
        for writer in self._writers.values():
            writer.add_text(tag, text, step=0)

    def close(self) -> None:
        for writer in self._writers.values():
            writer.close()
