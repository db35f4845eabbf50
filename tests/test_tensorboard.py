"""``jaxpg.run.outputs.tensorboard`` against tensorboardX, an independent writer of the same format: its
CRC-32C, its record framing, its protocol buffers byte for byte, and a run's event files read back
through its ``Event`` message."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from jaxpg.run.outputs import metrics_log, tensorboard

tbx = pytest.importorskip("tensorboardX")
from tensorboardX.crc32c import crc32c as reference_crc32c  # noqa: E402
from tensorboardX.proto.event_pb2 import Event, SessionLog  # noqa: E402
from tensorboardX.proto.summary_pb2 import Summary  # noqa: E402
from tensorboardX.record_writer import RecordWriter  # noqa: E402
from tensorboardX.summary import scalar as reference_scalar  # noqa: E402
from tensorboardX.summary import text as reference_text  # noqa: E402


def read_records(path) -> list[bytes]:
    """The data of each record of an event file, every checksum checked with tensorboardX's."""
    from tensorboardX.record_writer import masked_crc32c as reference_masked

    blob, out, at = path.read_bytes(), [], 0
    while at < len(blob):
        header = blob[at : at + 8]
        (length,) = struct.unpack("<Q", header)
        assert struct.unpack("<I", blob[at + 8 : at + 12])[0] == reference_masked(header)
        data = blob[at + 12 : at + 12 + length]
        assert struct.unpack("<I", blob[at + 12 + length : at + 16 + length])[0] == reference_masked(data)
        out.append(data)
        at += 16 + length
    return out


def test_crc32c_is_castagnolis():
    assert tensorboard.crc32c(b"123456789") == 0xE3069283  # the check value of CRC-32C
    rng = np.random.default_rng(0)
    for size in (0, 1, 7, 64, 1000):
        data = rng.integers(0, 256, size, dtype=np.uint8).tobytes()
        assert tensorboard.crc32c(data) == reference_crc32c(data)


def test_checksums_computed_together_are_tensorboardxs():
    """``crc32c_many`` (every payload advanced together in NumPy) against tensorboardX's CRC-32C,
    over payloads of different lengths, empty ones included; ``records`` frames as ``record``."""
    rng = np.random.default_rng(1)
    payloads = [rng.integers(0, 256, size, dtype=np.uint8).tobytes() for size in (0, 1, 513, 7, 0, 64, 300, 8)]
    assert tensorboard.crc32c_many(payloads).tolist() == [reference_crc32c(p) for p in payloads]
    assert tensorboard.crc32c_many([b"", b""]).tolist() == [0, 0]
    assert tensorboard.records(payloads) == [tensorboard.record(p) for p in payloads]
    assert tensorboard.records([]) == []


def test_records_are_framed_as_tensorboardx_frames_them(tmp_path):
    payloads = [b"", b"x", bytes(range(256)) * 3]
    path = tmp_path / "reference"
    writer = RecordWriter(str(path))
    for data in payloads:
        writer.write(data)
    writer.close()
    assert b"".join(tensorboard.record(data) for data in payloads) == path.read_bytes()


@pytest.mark.parametrize("value", [3310.5, 0.0, -1e-7, float("inf"), 1e30])
@pytest.mark.parametrize("step", [0, 1, 120, 2**40])
def test_scalar_events_are_tensorboardxs_bytes(value, step):
    wall_time = 1764380000.123456
    reference = Event(wall_time=wall_time, step=step, summary=reference_scalar("return_mean_policy", value))
    mine = tensorboard.event(wall_time, step, summary=tensorboard.scalar_summary("return_mean_policy", value))
    assert mine == reference.SerializeToString()


def test_several_scalars_in_one_event_are_tensorboardxs_summary_of_them():
    """One event per iteration and seed holds every metric: the ``Summary`` with one ``Value``
    per tag that TensorFlow's merged summaries wrote."""
    values = {"return_mean_policy": 3310.5, "kl": 0.0123, "wall_time_s": 61.25, "a/b c": -2.0}
    reference = Event(
        wall_time=5.5, step=9, summary=Summary(value=[Summary.Value(tag=k, simple_value=v) for k, v in values.items()])
    )
    mine = tensorboard.event(5.5, 9, summary=tensorboard.scalars_summary(values))
    assert mine == reference.SerializeToString()
    decoded = Event.FromString(mine)
    assert [(v.tag, v.simple_value) for v in decoded.summary.value] == [
        (k, float(np.float32(v))) for k, v in values.items()
    ]


def test_text_file_version_and_session_start_events_are_tensorboardxs_bytes():
    text = 'config\n```\n{"gamma": 0.995, "name": "h\u00f6pper"}\n```'
    reference = Event(wall_time=12.5, step=0, summary=reference_text("config", text))
    assert tensorboard.event(12.5, 0, summary=tensorboard.text_summary("config", text)) == reference.SerializeToString()
    version = Event(wall_time=12.5, step=7, file_version="brain.Event:2")
    assert tensorboard.event(12.5, 7, file_version="brain.Event:2") == version.SerializeToString()
    start = Event(wall_time=12.5, step=61, session_log=SessionLog(status=SessionLog.START))
    assert tensorboard.event(12.5, 61, session_start=True) == start.SerializeToString()


def test_a_runs_event_files_hold_its_metrics(tmp_path):
    """``TensorBoardLog``'s event files, read back with tensorboardX's ``Event``: every non-NaN
    metric of every iteration and seed, as float32, and the config text; a resumed writer starts
    its own file with a purge at its first step."""
    seeds = [3, 5]
    metrics = {
        "return_mean_policy": np.array([[1.0, np.nan], [2.5, 4.0]], np.float32),
        "kl": np.array([[0.01, 0.02], [0.03, 0.04]], np.float32),
    }
    writer = tensorboard.TensorBoardLog(tmp_path, seeds)
    writer.add_text("config", "gamma 0.995")
    writer.write(metrics_log.block_records(metrics, 0, seeds, [1.0, 2.0]))
    writer.close()
    for s, seed in enumerate(seeds):
        (path,) = (tmp_path / "tensorboard" / f"seed_{seed}").glob("events.out.tfevents.*")
        events = [Event.FromString(data) for data in read_records(path)]
        assert events[0].file_version == "brain.Event:2"
        texts = [e for e in events if e.summary.value and e.summary.value[0].tag == "config/text_summary"]
        assert [t.summary.value[0].tensor.string_val[0] for t in texts] == [b"gamma 0.995"]
        scalars = {
            (value.tag, e.step): value.simple_value
            for e in events
            for value in e.summary.value
            if value.HasField("simple_value")
        }
        expected = {
            (key, i + 1): float(values[i, s])
            for key, values in metrics.items()
            for i in range(2)
            if not np.isnan(values[i, s])
        }
        assert {k: v for k, v in scalars.items() if k[0] in metrics} == expected
        assert ("wall_time_s", 2) in scalars
    resumed = tensorboard.TensorBoardLog(tmp_path, seeds, start_iteration=1)
    resumed.close()
    files = sorted((tmp_path / "tensorboard" / "seed_3").glob("events.out.tfevents.*"))
    assert len(files) == 2
    starts = [Event.FromString(data) for data in read_records(files[-1])]
    assert starts[-1].session_log.status == SessionLog.START and starts[-1].step == 2
