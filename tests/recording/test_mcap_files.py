"""Recordings as files: what riverbridge writes, read back by independent readers (the `mcap`
library, mcap-ros2-support's decoder, rosbags' rosbag2 reader), and what the player reads."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader as Rosbag2Reader

from clients.recording.mcap_file import McapRecording
from clients.recording.player import ensure_type, restamp
from clients.recording.reading import read_recording
from clients.recording.topics import BRIDGE_OWNED, TopicFilter
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.message import normalize
from schemas.registry import TypeRegistry

from .messages import CLOUD, IMU, cloud, imu, write_reference_recording

START_NS = 1_800_000_000 * 1_000_000_000


def canonical(registry: TypeRegistry, type_name: str, msg: dict) -> dict:
    return normalize(registry.message(type_name), msg, now_ns=0)


def write_ours(
    path: Path, registry: TypeRegistry, imu_count: int = 30, clouds: int = 3, **options: object
) -> McapRecording:
    recording = McapRecording(path, **options)  # type: ignore[arg-type]
    for topic, type_name in (IMU, CLOUD):
        recording.add_topic(topic, type_name, registry.full_text(type_name))
    for k in range(imu_count):
        stamp_ns = START_NS + k * 10_000_000
        recording.add_message(
            IMU[0],
            to_cdr(registry, IMU[1], canonical(registry, IMU[1], imu(stamp_ns, k))),
            stamp_ns + 1000,
            stamp_ns + 500,
        )
        if k % 10 == 0 and k // 10 < clouds:
            recording.add_message(
                CLOUD[0],
                to_cdr(registry, CLOUD[1], cloud(stamp_ns, 20_000, k)),
                stamp_ns + 2000,
                stamp_ns + 1500,
            )
    return recording


def test_a_recording_has_ros2_schemas_cdr_channels_and_decodes_independently(
    tmp_path: Path, registry: TypeRegistry
) -> None:
    path = tmp_path / "run.mcap"
    write_ours(path, registry).close()
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count == 33
        schemas = {s.name: s for s in summary.schemas.values()}
        for _, type_name in (IMU, CLOUD):
            assert schemas[type_name].encoding == "ros2msg"
            assert schemas[type_name].data.decode() == registry.full_text(type_name)
        for channel in summary.channels.values():
            assert channel.message_encoding == "cdr"
            assert channel.metadata == {"offered_qos_profiles": ""}
        decoded = [
            (channel.topic, message, ros_msg)
            for _, channel, message, ros_msg in reader.iter_decoded_messages()
        ]
    clouds = [(message, msg) for topic, message, msg in decoded if topic == CLOUD[0]]
    assert len(clouds) == 3
    message, first = clouds[0]
    expected = cloud(START_NS, 20_000, 0)
    assert [f.name for f in first.fields] == ["x", "y", "z", "intensity"]
    assert (first.width, first.point_step, first.header.frame_id) == (20_000, 16, "lidar")
    assert bytes(first.data) == expected["data"]
    xyz = np.frombuffer(bytes(first.data), np.float32).reshape(-1, 4)
    assert xyz.shape == (20_000, 4)
    assert (message.log_time, message.publish_time) == (START_NS + 2000, START_NS + 1500)
    yaw_rates = [msg.angular_velocity.z for topic, _, msg in decoded if topic == IMU[0]]
    assert yaw_rates == [float(k) for k in range(30)]


def test_rosbags_rosbag2_reader_reads_a_recording(tmp_path: Path, registry: TypeRegistry) -> None:
    """rosbags implements rosbag2's MCAP storage: topics, types, counts and messages."""
    path = tmp_path / "run.mcap"
    write_ours(path, registry).close()
    with Rosbag2Reader(path) as bag:
        assert {t: (i.msgtype, i.msgcount) for t, i in bag.topics.items()} == {
            IMU[0]: (IMU[1], 30),
            CLOUD[0]: (CLOUD[1], 3),
        }
        connection = next(c for c in bag.connections if c.topic == CLOUD[0])
        raw = next(data for _, _, data in bag.messages(connections=[connection]))
    assert from_cdr(registry, CLOUD[1], raw)["width"] == 20_000


def complete_chunks(path: Path) -> int:
    """Messages in the Chunk records a streaming reader finds whole (up to a truncation)."""
    from mcap.records import Chunk

    count = 0
    with open(path, "rb") as stream:
        try:
            for record in StreamReader(stream, emit_chunks=True).records:
                if isinstance(record, Chunk):
                    count += 1
        except Exception:  # the cut-off record at the end
            pass
    return count


def test_a_cut_off_recording_reads_up_to_its_last_complete_chunk(
    tmp_path: Path, registry: TypeRegistry
) -> None:
    """What a killed recorder leaves: the file without its summary, ending mid-chunk."""
    whole = tmp_path / "whole.mcap"
    write_ours(whole, registry, imu_count=30, clouds=3, chunk_bytes=64 * 1024).close()
    data = whole.read_bytes()
    cut = tmp_path / "cut.mcap"
    # the last cloud's chunk starts after 20 IMU samples; cut inside it
    cut.write_bytes(data[: int(len(data) * 0.85)])
    assert complete_chunks(cut) >= 2
    messages = list(read_recording(cut, TopicFilter()))
    clouds = [m for m in messages if m.topic == CLOUD[0]]
    assert 1 <= len(clouds) <= 2 and len(messages) >= 11
    assert from_cdr(registry, CLOUD[1], clouds[0].cdr)["width"] == 20_000
    assert [
        from_cdr(registry, IMU[1], m.cdr)["angular_velocity"]["z"]
        for m in messages
        if m.topic == IMU[0]
    ] == [float(k) for k in range(sum(m.topic == IMU[0] for m in messages))]


def test_reading_takes_the_wanted_topics_in_time_order(
    tmp_path: Path, registry: TypeRegistry
) -> None:
    path = tmp_path / "reference.mcap"
    events = write_reference_recording(
        path, registry, start_ns=START_NS, imu_hz=50, cloud_hz=2, seconds=1.0
    )
    messages = list(read_recording(path, TopicFilter(("/imu/*",))))
    assert [m.log_time_ns for m in messages] == [t for topic, t, _ in events if topic == IMU[0]]
    assert {m.type_name for m in messages} == {IMU[1]}


def test_topic_filters() -> None:
    everything = TopicFilter()
    assert everything("/anything") and everything("/rosout")
    player_default = TopicFilter(excluded=BRIDGE_OWNED)
    assert player_default("/lidar/points")
    assert not player_default("/rosout") and not player_default("/riverbridge/trace")
    asked = TopicFilter(("/riverbridge/*", "/imu/data"))
    assert asked("/riverbridge/trace") and asked("/imu/data") and not asked("/imu/raw")


def test_restamp_moves_every_nested_header() -> None:
    tf = {
        "transforms": [
            {"header": {"stamp": {"sec": 1, "nanosec": 5}, "frame_id": "a"}},
            {"header": {"stamp": {"sec": 2, "nanosec": 999_999_999}}},
        ]
    }
    restamp(tf, lambda ns: ns + 1)
    assert [t["header"]["stamp"] for t in tf["transforms"]] == [
        {"sec": 1, "nanosec": 6},
        {"sec": 3, "nanosec": 0},
    ]
    sample = imu(5_000_000_000, 1)
    restamp(sample, lambda ns: ns * 2)
    assert sample["header"]["stamp"] == {"sec": 10, "nanosec": 0}


def test_a_type_unknown_here_is_registered_from_the_recording() -> None:
    registry = TypeRegistry.with_defaults()
    definition = (
        "geometry_msgs/Point where\nint32 count\n"
        + "=" * 80
        + "\nMSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n"
    )
    with pytest.raises(Exception, match="elsewhere_msgs"):
        registry.message("elsewhere_msgs/msg/Thing")
    ensure_type(registry, "elsewhere_msgs/msg/Thing", definition)
    msg = {"where": {"x": 1.0, "y": 2.0, "z": 3.0}, "count": 7}
    assert (
        from_cdr(
            registry, "elsewhere_msgs/msg/Thing", to_cdr(registry, "elsewhere_msgs/msg/Thing", msg)
        )
        == msg
    )
