"""Seek, pause and speed of `riverbridge play` from a Foxglove client connected to the bridge.

A real bridge and a real `riverbridge play --stay` process (the recording written with
mcap-ros2-support's writer); the Node scenario (js/foxglove_playback.mjs) connects with the
SDK's subprotocol and drives playback with binary PlaybackControlRequests while subscribed
to the IMU; roslibpy on the same port sees the player's state topic throughout.
"""

from __future__ import annotations

import asyncio
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import roslibpy

from schemas.registry import TypeRegistry
from tests.child_process import REPO_ROOT
from tests.recording.messages import IMU, NS_PER_S, write_reference_recording

from . import roslibpy_support as rp
from .bridge_process import BridgeEndpoint
from .node_runner import run_scenario

START_NS = 1_700_000_000 * NS_PER_S
IMU_HZ = 50
SECONDS = 8.0
SEEK_OFFSET_S = 5.0
STATE_TOPIC = "/riverbridge/playback/state"


@pytest.fixture
def player(bridge: BridgeEndpoint, tmp_path: Path) -> Iterator[subprocess.Popen[str]]:
    """`riverbridge play --stay` of an 8 s recording (IMU at 50 Hz, small clouds)."""
    path = tmp_path / "run.mcap"
    write_reference_recording(
        path,
        TypeRegistry.with_defaults(),
        start_ns=START_NS,
        imu_hz=IMU_HZ,
        cloud_hz=1,
        seconds=SECONDS,
        cloud_points=100,
    )
    command = [sys.executable, str(REPO_ROOT / "riverbridge.py"), "play", str(path)]
    process = subprocess.Popen(
        [*command, "--bridge", bridge.url, "--stay"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        yield process
    finally:
        process.terminate()
        process.communicate(timeout=20)


async def test_foxglove_client_pauses_seeks_and_speeds_up_the_player(
    bridge: BridgeEndpoint, player: subprocess.Popen[str], log_trap: rp.LogTrap
) -> None:
    states = rp.Inbox()
    with rp.connected(bridge.host, bridge.port) as ros:
        roslibpy.Topic(ros, STATE_TOPIC, "riverbridge_msgs/msg/PlaybackState").subscribe(states)
        states.expect(1, timeout_s=30.0)  # the player is there before the Foxglove client
        result = await asyncio.to_thread(
            run_scenario, "foxglove_playback.mjs", bridge.url, IMU[0], str(SEEK_OFFSET_S)
        )
        last_state = states.snapshot()[-1]

    assert player.poll() is None, "the player left before the test ended"
    assert result["protocol"] == "foxglove.sdk.v1"
    assert result["errors"] == []
    info = result["serverInfo"]
    assert {"time", "playbackControl"} <= set(info["capabilities"])
    assert info["dataStartTime"] == {"sec": START_NS // NS_PER_S, "nsec": 0}
    assert info["dataEndTime"]["sec"] in range(START_NS // NS_PER_S + 7, START_NS // NS_PER_S + 9)

    assert result["paused"]["status"] == 1  # PAUSED
    assert result["duringPause"] == 0

    seek_target = int(result["seekTarget"])
    assert seek_target == START_NS + int(SEEK_OFFSET_S * NS_PER_S)
    seeked = result["seeked"]
    assert seeked["didSeek"] is True and seeked["status"] == 0  # PLAYING
    assert abs(int(seeked["currentTime"]) - seek_target) < NS_PER_S // 2
    after = result["afterSeek"]
    # The IMU sample's yaw rate is its index at 50 Hz: the first one after the seek is the
    # one recorded at the seek time (give or take what was due while the request travelled).
    index = after["message"]["angular_velocity"]["z"]
    assert SEEK_OFFSET_S * IMU_HZ <= index < (SEEK_OFFSET_S + 0.5) * IMU_HZ
    # Its timestamp is on the playback clock (the recording's 2023), not today's: near the
    # seek target, give or take the player's read-ahead after the seek on a loaded machine.
    assert abs(int(after["timestamp"]) - seek_target) < 2 * NS_PER_S

    assert result["faster"]["speed"] == 2.0 and result["faster"]["status"] == 0
    assert START_NS <= int(result["firstTime"]) <= START_NS + int(SECONDS * NS_PER_S)
    assert int(result["lastTime"]) >= seek_target
    assert last_state["speed"] == 2.0
