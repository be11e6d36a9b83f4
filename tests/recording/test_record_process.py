"""`riverbridge record` as a real process against a real bridge: what it records, how it picks
up new topics and globs, and what a kill -9 leaves (read by the `mcap` library's streaming
reader, not ours)."""

from __future__ import annotations

import asyncio
import signal
import time
from pathlib import Path

import pytest
from mcap.exceptions import EndOfFile, McapError
from mcap.reader import NonSeekingReader, SeekingReader
from mcap_ros2.decoder import DecoderFactory

from clients import RosbridgeClient
from schemas.codec_cdr import from_cdr
from schemas.registry import TypeRegistry
from tests.child_process import Running

from .conftest import RIVERBRIDGE
from .messages import CLOUD, IMU, cloud, imu

pytestmark = pytest.mark.slow

THESIS_SCAN_POINTS = 345_600  # 5.5 MB PointCloud2 (Table 4.3)


def start_recorder(url: str, output: Path, *extra: str) -> Running:
    return Running([*RIVERBRIDGE, "record", "--bridge", url, "--output", str(output), *extra])


async def publish(
    client: RosbridgeClient, imu_count: int, imu_hz: float, cloud_every: int, cloud_points: int
) -> int:
    """IMU samples (yaw rate = index) with a cloud every ``cloud_every`` samples; the number
    of clouds sent."""
    clouds = 0
    for k in range(imu_count):
        now_ns = time.time_ns()
        await client.publish(IMU[0], imu(now_ns, k))
        if k % cloud_every == 0:
            await client.publish(CLOUD[0], cloud(now_ns, cloud_points, k))
            clouds += 1
        await asyncio.sleep(1 / imu_hz)
    return clouds


def decoded(path: Path) -> list[tuple[str, object]]:
    """(topic, mcap-ros2-support's decoded message) of a finished file, in log-time order."""
    with open(path, "rb") as stream:
        reader = SeekingReader(stream, decoder_factories=[DecoderFactory()])
        return [(channel.topic, msg) for _, channel, _, msg in reader.iter_decoded_messages()]


async def test_record_takes_every_message_of_new_topics_and_honours_globs(
    bridge_url: str, tmp_path: Path
) -> None:
    everything, imu_only = tmp_path / "all.mcap", tmp_path / "imu.mcap"
    recorders = [
        start_recorder(bridge_url, everything),
        start_recorder(bridge_url, imu_only, "--topics", "/imu/*"),
    ]
    try:
        recorders[0].wait_for_line(r"recording /rosout")  # its first discovery is done
        recorders[1].wait_for_line(r"recorder connected")
        async with RosbridgeClient(bridge_url, name="publisher") as client:
            for topic in (IMU, CLOUD):  # appear after the recorders started
                await client.advertise(*topic)
            for recorder in recorders:
                recorder.wait_for_line(r"recording /imu/data", timeout_s=20)
            recorders[0].wait_for_line(r"recording /lidar/points", timeout_s=20)
            clouds = await publish(
                client, imu_count=100, imu_hz=100, cloud_every=25, cloud_points=THESIS_SCAN_POINTS
            )
            for path in (everything, imu_only):  # on disk before the stop: the condition
                await written(path, imu_samples=100)
    finally:
        codes = [recorder.stop() for recorder in recorders]
    assert codes == [0, 0], "\n".join(r.text() for r in recorders)
    assert "wrote" in recorders[0].text() and "DROPPED" not in recorders[0].text()
    messages = decoded(everything)
    yaw_rates = [msg.angular_velocity.z for topic, msg in messages if topic == IMU[0]]
    assert yaw_rates == [float(k) for k in range(100)]
    scans = [msg for topic, msg in messages if topic == CLOUD[0]]
    assert len(scans) == clouds == 4
    assert bytes(scans[1].data) == cloud(0, THESIS_SCAN_POINTS, 25)["data"]
    assert {topic for topic, _ in decoded(imu_only)} == {IMU[0]}


def read_until_cut(path: Path) -> tuple[list[float], bool]:
    """The IMU yaw rates a streaming reader gets from ``path`` and whether the file ended
    early (no summary: the recorder died)."""
    registry = TypeRegistry.with_defaults()
    yaw_rates: list[float] = []
    cut = False
    with open(path, "rb") as stream:
        try:
            for _, channel, message in NonSeekingReader(stream).iter_messages(log_time_order=False):
                if channel.topic == IMU[0]:
                    msg = from_cdr(registry, IMU[1], message.data)
                    yaw_rates.append(msg["angular_velocity"]["z"])
        except EndOfFile:
            cut = True
    return yaw_rates, cut


async def written(path: Path, imu_samples: int, timeout_s: float = 30.0) -> None:
    """Wait until the recorder's file holds ``imu_samples`` IMU samples (its chunks close at
    least once a second, so a reader of the unfinished file sees them)."""
    async with asyncio.timeout(timeout_s):
        while True:
            try:
                yaw_rates, _ = await asyncio.to_thread(read_until_cut, path)
            except (McapError, FileNotFoundError):  # not even a first chunk yet
                yaw_rates = []
            if len(yaw_rates) >= imu_samples:
                return
            await asyncio.sleep(0.1)


async def test_a_killed_recorder_leaves_a_file_readable_to_its_last_chunk(
    bridge_url: str, tmp_path: Path
) -> None:
    path = tmp_path / "killed.mcap"
    recorder = start_recorder(bridge_url, path)
    try:
        async with RosbridgeClient(bridge_url, name="publisher") as client:
            for topic in (IMU, CLOUD):
                await client.advertise(*topic)
            recorder.wait_for_line(r"recording /lidar/points", timeout_s=20)
            await publish(client, imu_count=250, imu_hz=100, cloud_every=50, cloud_points=50_000)
            recorder.process.send_signal(signal.SIGKILL)  # while messages are in flight
            recorder.process.wait(timeout=10)
            sent_before_kill = 250
            await publish(client, imu_count=10, imu_hz=100, cloud_every=50, cloud_points=10)
    finally:
        recorder.kill_session()
    # no footer: the recorder never finished (mcap says so with one of its own errors: the
    # magic that ends a complete file is missing, or the file ends inside a record)
    with open(path, "rb") as stream, pytest.raises(McapError):
        SeekingReader(stream).get_summary()
    yaw_rates, cut = read_until_cut(path)
    # chunks close at least once a second: ~1 s of the 2.5 s may be lost, never the rest
    assert len(yaw_rates) >= sent_before_kill - 120, (len(yaw_rates), cut)
    assert yaw_rates == [float(k) for k in range(len(yaw_rates))]
