"""`python -m clients.stack.healthcheck` against a real bridge process."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator

import pytest

from clients import RosbridgeClient
from clients.stack.healthcheck import Unhealthy, check
from tests.child_process import Running, free_port, run_command

pytestmark = pytest.mark.slow

_LISTENING = r"listening on ws://127\.0\.0\.1:(?P<port>\d+)"


@pytest.fixture(scope="module")
def bridge_url() -> Iterator[str]:
    bridge = Running([sys.executable, "-m", "bridge", "--host", "127.0.0.1", "--port", "0"])
    try:
        port = bridge.wait_for_line(_LISTENING).group("port")
        yield f"ws://127.0.0.1:{port}"
        assert bridge.stop() == 0, bridge.text()
    finally:
        bridge.kill_session()


def healthcheck(*args: str) -> subprocess.CompletedProcess[str]:
    return run_command([sys.executable, "-m", "clients.stack.healthcheck", *args])


def test_a_listening_bridge_is_healthy(bridge_url: str) -> None:
    result = healthcheck("--bridge", bridge_url)
    assert result.returncode == 0, result.stderr


def test_a_topic_without_publisher_is_unhealthy_and_named(bridge_url: str) -> None:
    result = healthcheck("--bridge", bridge_url, "--topic", "/rosout", "--topic", "/lidar/points")
    assert result.returncode == 1
    assert "no publisher on /lidar/points" in result.stderr
    assert "/rosout," not in result.stderr  # the bridge itself publishes /rosout


async def test_a_subscriber_alone_does_not_make_a_topic_healthy(bridge_url: str) -> None:
    async with RosbridgeClient(bridge_url, encoding="json") as listener:
        await listener.subscribe("/imu/data", "sensor_msgs/msg/Imu")
        with pytest.raises(Unhealthy, match="no publisher on /imu/data"):
            await check(bridge_url, ["/imu/data"], timeout_s=20.0)


async def test_an_advertised_topic_is_healthy(bridge_url: str) -> None:
    async with RosbridgeClient(bridge_url, encoding="json") as talker:
        await talker.advertise("/gnss/fix", "sensor_msgs/msg/NavSatFix")
        await talker.call_service("/rosapi/get_time", timeout=20.0)  # advertise applied
        version = await check(bridge_url, ["/gnss/fix"], timeout_s=20.0)
    assert version["protocol"]


def test_nothing_listening_is_unhealthy() -> None:
    result = healthcheck("--bridge", f"ws://127.0.0.1:{free_port()}", "--timeout", "2")
    assert result.returncode == 1
    assert "GET http://127.0.0.1:" in result.stderr


def test_a_bad_bridge_url_is_a_usage_error() -> None:
    result = healthcheck("--bridge", "bridge:9090")
    assert result.returncode == 2
    assert "--bridge" in result.stderr
