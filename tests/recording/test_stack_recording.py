"""Recording and replaying the real stack: `up --record`, `report --bridge --record` and
`report --replay`, each through its command line."""

from __future__ import annotations

import asyncio
import json
import subprocess
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from clients.client import RosbridgeClient
from clients.stack.launcher import NAVIGATION_TOPICS, SIMULATOR_TOPICS
from tests.launcher.processes import UpProcess
from tests.receiving import collect

from .conftest import RIVERBRIDGE

pytestmark = [pytest.mark.slow, pytest.mark.timeout(600)]


def topic_counts(path: Path) -> tuple[dict[str, int], object]:
    """Messages per topic from the file's summary, and one decoded PointCloud2."""
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None, f"{path} unfinished"
        counts = {
            channel.topic: summary.statistics.channel_message_counts.get(channel_id, 0)
            for channel_id, channel in summary.channels.items()
        }
        scan = next(msg for _, _, _, msg in reader.iter_decoded_messages(topics=["/lidar/points"]))
    return counts, scan


async def navigation_boxes(url: str, timeout_s: float = 90.0) -> int:
    """Wait for the stack's first LIDAR boxes: navigation's LIDAR worker takes seconds to
    start (scikit-learn's import), and an attached report must find navigation at work."""
    async with RosbridgeClient(url, name="boxes-probe") as client:
        boxes = await client.subscribe("/nav/boxes")
        return len(await collect(boxes, 1, timeout_s))


def report(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*RIVERBRIDGE, "report", "--warmup", "2", *args],
        capture_output=True,
        text=True,
        timeout=400,
    )


def test_record_the_stack_then_measure_navigation_on_the_replay(tmp_path: Path) -> None:
    stack_file, attached_file = tmp_path / "stack.mcap", tmp_path / "attached.mcap"
    up = UpProcess("--record", str(stack_file))
    try:
        url = up.wait_ready()
        assert asyncio.run(navigation_boxes(url)) == 1, "navigation published no boxes"
        attached = report("--bridge", url, "--duration", "3", "--record", str(attached_file))
    finally:
        code = up.stop()
        up.kill_session()
    assert code == 0, up.text()
    assert attached.returncode == 0, attached.stdout + attached.stderr
    for path in (stack_file, attached_file):
        counts, scan = topic_counts(path)
        for topic in (*SIMULATOR_TOPICS, *NAVIGATION_TOPICS):
            assert counts.get(topic, 0) > 0, (path.name, topic, counts)
        assert scan.width * scan.height > 10_000 and scan.point_step == 16

    replay_json = tmp_path / "replay.json"
    replayed = report("--replay", str(stack_file), "--duration", "4", "--json", str(replay_json))
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert replayed.stdout.startswith(f"REPLAY of {stack_file}")
    run = json.loads(replay_json.read_text())["runs"][0]
    assert run["encoding"] == "cbor replay"
    assert "simulator" not in run["processes"] and "player" in run["processes"]
    lidar = run["topics"]["/lidar/points"]["stages"]
    assert lidar["process"]["n"] > 0  # navigation clustered the recorded scans
    assert lidar["transport"]["n"] > 0 and lidar["transport"]["p50"] < 500
    assert "/nav/boxes" in run["topics"]
