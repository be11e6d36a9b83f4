"""`riverbridge play` as a real process into a real bridge, with a subscriber on the other side:
count and order kept, paced rather than a burst, rate scaling, looping and the three stamp
modes. How closely playback keeps time depends on the machine's load and is not asserted.
The recordings are written with mcap-ros2-support's writer, not riverbridge's."""

from __future__ import annotations

import asyncio
import itertools
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from clients import RosbridgeClient
from schemas.registry import TypeRegistry

from .conftest import RIVERBRIDGE
from .messages import CLOUD, IMU, NS_PER_S, write_reference_recording

pytestmark = pytest.mark.slow

START_NS = 1_700_000_000 * NS_PER_S  # recorded in 2023: far from today's clock


@dataclass(frozen=True)
class Arrival:
    topic: str
    index: int  # IMU yaw rate, cloud: the point count's seed is not visible, use order
    stamp_ns: int
    recv_ns: int


def stamp_ns(msg: dict) -> int:
    return int(msg["header"]["stamp"]["sec"]) * NS_PER_S + int(msg["header"]["stamp"]["nanosec"])


async def play_and_receive(
    url: str, recording: Path, *options: str, timeout_s: float = 60.0
) -> tuple[list[Arrival], str]:
    """Run `riverbridge play` with ``options`` while subscribed to both topics; the arrivals
    and the player's output."""
    async with RosbridgeClient(url, name="listener") as client:
        subs = [
            await client.subscribe(topic, type_name, maxsize=100_000)
            for topic, type_name in (IMU, CLOUD)
        ]
        player = await asyncio.create_subprocess_exec(
            *RIVERBRIDGE,
            "play",
            str(recording),
            "--bridge",
            url,
            *options,
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.STDOUT,
        )
        output, _ = await asyncio.wait_for(player.communicate(), timeout_s)
        assert player.returncode == 0, output.decode()
        played = played_counts(output.decode())
        arrivals: list[Arrival] = []
        async with asyncio.timeout(timeout_s):  # until all the player says it sent is here
            for sub in subs:
                for _ in range(played.get(sub.topic, 0)):
                    item = await sub.get()
                    index = int(item.msg["angular_velocity"]["z"]) if sub.topic == IMU[0] else 0
                    arrivals.append(Arrival(sub.topic, index, stamp_ns(item.msg), item.recv_ns))
        assert all(sub.get_nowait() is None for sub in subs), "more arrived than was played"
    return sorted(arrivals, key=lambda a: a.recv_ns), output.decode()


def played_counts(output: str) -> dict[str, int]:
    """Messages per topic from the player's summary lines (``  /topic   N msgs``)."""
    return {
        match[1]: int(match[2]) for match in re.finditer(r"^\s+(/\S+)\s+(\d+) msgs$", output, re.M)
    }


def recording(tmp_path: Path, seconds: float) -> tuple[Path, list[tuple[str, int, int]]]:
    path = tmp_path / "reference.mcap"
    events = write_reference_recording(
        path,
        TypeRegistry.with_defaults(),
        start_ns=START_NS,
        imu_hz=100,
        cloud_hz=2,
        seconds=seconds,
        cloud_points=100_000,
    )
    return path, events


def check_paced(arrivals: list[Arrival], events: list[tuple[str, int, int]], rate: float) -> None:
    """The player paces the recording instead of sending it in one burst: the IMU samples
    arrive over at least half the recording's span / rate (a burst takes a few ms). How
    closely it keeps time is a timing claim a loaded machine decides, so it is not held here:
    the player's summary prints how late publishing ran."""
    recorded = {(topic, index): log_ns for topic, log_ns, index in events}
    imu = [a for a in arrivals if a.topic == IMU[0]]
    received_span_s = (imu[-1].recv_ns - imu[0].recv_ns) / NS_PER_S
    recorded_span_s = (
        (recorded[(IMU[0], imu[-1].index)] - recorded[(IMU[0], imu[0].index)]) / NS_PER_S / rate
    )
    assert received_span_s >= 0.5 * recorded_span_s, (received_span_s, recorded_span_s)


async def test_play_keeps_count_order_and_timing(bridge_url: str, tmp_path: Path) -> None:
    path, events = recording(tmp_path, seconds=3.0)
    arrivals, output = await play_and_receive(bridge_url, path)
    assert "played" in output and "1 pass(es)" in output
    imu = [a for a in arrivals if a.topic == IMU[0]]
    assert [a.index for a in imu] == [index for topic, _, index in events if topic == IMU[0]]
    assert sum(a.topic == CLOUD[0] for a in arrivals) == sum(t == CLOUD[0] for t, _, _ in events)
    check_paced(arrivals, events, rate=1.0)
    # shifted stamps: the recorded spacing exactly, and on today's clock (not 2023's): stamped
    # before they arrive, and well within the few seconds the play took
    assert {b.stamp_ns - a.stamp_ns for a, b in itertools.pairwise(imu)} == {10_000_000}
    assert all(0 <= a.recv_ns - a.stamp_ns < 10 * NS_PER_S for a in imu)


async def test_play_at_twice_the_rate_halves_the_timing_and_the_stamps(
    bridge_url: str, tmp_path: Path
) -> None:
    path, events = recording(tmp_path, seconds=4.0)
    arrivals, _ = await play_and_receive(bridge_url, path, "--rate", "2")
    assert len(arrivals) == len(events)
    check_paced(arrivals, events, rate=2.0)
    imu = [a for a in arrivals if a.topic == IMU[0]]
    assert {b.stamp_ns - a.stamp_ns for a, b in itertools.pairwise(imu)} == {5_000_000}


async def test_loop_plays_again_with_stamps_that_keep_increasing(
    bridge_url: str, tmp_path: Path
) -> None:
    path, events = recording(tmp_path, seconds=1.0)
    arrivals, output = await play_and_receive(
        bridge_url, path, "--loop", "--duration", "6", "--topics", "/imu/*"
    )
    imu = [a for a in arrivals if a.topic == IMU[0]]
    one_pass = sum(t == IMU[0] for t, _, _ in events)
    assert {a.topic for a in arrivals} == {IMU[0]}
    # a second pass began, from the first sample (how many passes 6 s hold: a matter of load)
    assert re.search(r"in [2-6] pass\(es\)", output), output
    assert len(imu) > one_pass and imu[one_pass].index == 0
    assert [a.index for a in imu[:one_pass]] == list(range(one_pass))
    stamps = [a.stamp_ns for a in imu]
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)


@pytest.mark.parametrize("mode", ["keep", "now"])
async def test_stamp_modes(bridge_url: str, tmp_path: Path, mode: str) -> None:
    path, events = recording(tmp_path, seconds=0.5)
    arrivals, _ = await play_and_receive(
        bridge_url, path, "--stamps", mode, "--topics", "/imu/data"
    )
    imu = [a for a in arrivals if a.topic == IMU[0]]
    recorded = [log_ns for topic, log_ns, _ in events if topic == IMU[0]]
    if mode == "keep":
        assert [a.stamp_ns for a in imu] == recorded
    else:  # stamped when sent, on today's clock (the recording is from 2023)
        assert all(0 <= a.recv_ns - a.stamp_ns < 10 * NS_PER_S for a in imu)


def test_play_refuses_what_it_cannot_play(tmp_path: Path) -> None:
    import subprocess

    missing = subprocess.run(
        [*RIVERBRIDGE, "play", str(tmp_path / "nope.mcap")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert missing.returncode == 2 and "no such file" in missing.stderr
    not_mcap = tmp_path / "notes.mcap"
    not_mcap.write_text("hello")
    refused = subprocess.run(
        [*RIVERBRIDGE, "play", str(not_mcap)], capture_output=True, text=True, timeout=60
    )
    assert refused.returncode == 2 and "not an MCAP file" in refused.stderr, refused.stderr
    path, _ = recording(tmp_path, seconds=0.1)
    rate = subprocess.run(
        [*RIVERBRIDGE, "play", str(path), "--rate", "0"], capture_output=True, text=True, timeout=60
    )
    assert rate.returncode == 2 and "--rate" in rate.stderr
    unreachable = subprocess.run(
        [*RIVERBRIDGE, "play", str(path), "--bridge", "ws://127.0.0.1:9", "--connect-timeout", "1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert unreachable.returncode == 1 and "cannot reach the bridge" in unreachable.stderr
