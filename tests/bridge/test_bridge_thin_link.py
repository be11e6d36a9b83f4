"""Over a thin link (docs/bridge.md, "Over a thin link"): one connection through the link
emulator carries a 100 kB "scan" topic at 20 Hz, twice what the link takes, for 2 s, beside
a 100 Hz IMU. With `queue_length: 1` and `fragment_size` the client gets the newest scans, whole,
and IMU samples between their fragments; without them it gets every scan, in order."""

from __future__ import annotations

import asyncio
import json
import re
import time
from collections.abc import AsyncIterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest
import websockets

from bridge.compose import RunningBridge, run_bridge
from bridge.config import BridgeConfig
from clients.linkemu import Direction, LinkEmulator, LinkProfile
from schemas import codec_cbor

pytestmark = pytest.mark.timeout(60)

SCAN_BYTES, SCANS, SCAN_HZ = 100_000, 40, 20.0
IMU_HZ = 100.0
FRAGMENT = 16_384
# 8 Mbit/s: a scan takes 0.1 s to cross, the IMU sample 0.4 ms; 10 ms each way
LINK = LinkProfile(
    name="thin",
    to_client=Direction(rate_bps=8e6, delay_ms=10, buffer_bytes=20_000),
    to_server=Direction(rate_bps=8e6, delay_ms=10, buffer_bytes=20_000),
)


@pytest.fixture
async def bridge(registry) -> AsyncIterator[RunningBridge]:
    async with run_bridge(BridgeConfig(port=0), registry) as running:
        yield running


@dataclass
class Seen:
    """What the subscriber read: scans (seq, age s, intact), IMU (seq, age s), and how many
    IMU samples arrived while a scan was half-way through its fragments."""

    scans: list[tuple[int, float, bool]] = field(default_factory=list)
    imu: list[tuple[int, float]] = field(default_factory=list)
    imu_between_fragments: int = 0
    metrics: str = ""  # the bridge's /metrics while the subscriber was still connected


def stamp_now() -> dict[str, int]:
    ns = time.time_ns()
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def age_s(msg: dict[str, Any]) -> float:
    stamp = msg["header"]["stamp"]
    return time.time() - (stamp["sec"] + stamp["nanosec"] / 1e9)


def scan_bytes(seq: int) -> bytes:
    return np.random.default_rng(seq).integers(0, 256, SCAN_BYTES, dtype=np.uint8).tobytes()


async def publish(url: str) -> None:
    """SCANS scans at SCAN_HZ and the IMU at IMU_HZ for as long, on one CBOR connection."""
    async with websockets.connect(url, max_size=None, compression=None) as ws:
        for topic, type_name in (
            ("/scan", "sensor_msgs/msg/CompressedImage"),
            ("/imu", "sensor_msgs/msg/Imu"),
        ):
            await ws.send(json.dumps({"op": "advertise", "topic": topic, "type": type_name}))
        start = time.monotonic()
        imu_seq = 0
        for seq in range(SCANS):
            header = {"stamp": stamp_now(), "frame_id": str(seq)}
            scan = {"header": header, "format": "raw", "data": scan_bytes(seq)}
            await ws.send(codec_cbor.dumps({"op": "publish", "topic": "/scan", "msg": scan}))
            while imu_seq < (seq + 1) * IMU_HZ / SCAN_HZ:
                await asyncio.sleep(max(0.0, start + imu_seq / IMU_HZ - time.monotonic()))
                imu = {"header": {"stamp": stamp_now(), "frame_id": str(imu_seq)}}
                await ws.send(codec_cbor.dumps({"op": "publish", "topic": "/imu", "msg": imu}))
                imu_seq += 1


async def subscribe_and_read(
    bridge: RunningBridge, link: LinkEmulator, scan_options: dict[str, Any], until_scan: int
) -> Seen:
    """Subscribe on one connection through `link`, publish on the bridge's host; read until
    scan `until_scan` is in."""
    seen = Seen()
    pieces: dict[Any, dict[int, bytes]] = {}
    url = f"ws://127.0.0.1:{link.port}"
    async with websockets.connect(url, max_size=None, compression=None) as ws:
        for topic, type_name, options in (
            ("/imu", "sensor_msgs/msg/Imu", {}),
            ("/scan", "sensor_msgs/msg/CompressedImage", scan_options),
        ):
            op = {"op": "subscribe", "topic": topic, "type": type_name, "compression": "cbor"}
            await ws.send(json.dumps({**op, **options}))
        await settle(ws)  # subscribed before the first message is published
        publisher = asyncio.create_task(publish(f"ws://127.0.0.1:{bridge.port}"))
        try:
            while True:
                async with asyncio.timeout(3.0):
                    op = codec_cbor.loads(await ws.recv())
                if op["op"] == "fragment":
                    parts = pieces.setdefault(op["id"], {})
                    parts[op["num"]] = op["data"]
                    if len(parts) < op["total"]:
                        continue
                    del pieces[op["id"]]
                    op = codec_cbor.loads(b"".join(parts[i] for i in range(op["total"])))
                msg = op["msg"]
                seq = int(msg["header"]["frame_id"])
                if op["topic"] == "/imu":
                    seen.imu.append((seq, age_s(msg)))
                    seen.imu_between_fragments += bool(pieces)
                    continue
                seen.scans.append((seq, age_s(msg), bytes(msg["data"]) == scan_bytes(seq)))
                if seq == until_scan:
                    until_imu = int(SCANS * IMU_HZ / SCAN_HZ) - 1
                    while not seen.imu or seen.imu[-1][0] < until_imu:  # the last IMU samples
                        async with asyncio.timeout(3.0):
                            op = codec_cbor.loads(await ws.recv())
                        if op.get("topic") == "/imu":
                            msg = op["msg"]
                            seen.imu.append((int(msg["header"]["frame_id"]), age_s(msg)))
                    break
        finally:
            await publisher
        seen.metrics = await fetch_metrics(bridge.port)
    return seen


async def test_the_newest_scans_arrive_whole_with_the_imu_between_their_fragments(bridge):
    async with LinkEmulator(LINK, ("127.0.0.1", bridge.port)) as link:
        options = {"queue_length": 1, "fragment_size": FRAGMENT}
        seen = await subscribe_and_read(bridge, link, options, until_scan=SCANS - 1)
    seqs = [seq for seq, _, _ in seen.scans]
    assert all(intact for _, _, intact in seen.scans)
    assert seqs == sorted(seqs) and seqs[-1] == SCANS - 1  # in order, and the newest arrived
    # the link takes about half of them: the others were conflated, not queued for later
    assert len(seqs) < SCANS * 0.8, seqs
    scan_ages = sorted(age for _, age, _ in seen.scans)
    assert scan_ages[len(scan_ages) // 2] < 0.5  # a backlog of every scan would be ~1 s
    # every IMU sample, and not behind whole scans: fragments let them through
    assert [seq for seq, _ in seen.imu] == list(range(int(SCANS * IMU_HZ / SCAN_HZ)))
    assert seen.imu_between_fragments > 0
    imu_ages = sorted(age for _, age in seen.imu)
    assert imu_ages[len(imu_ages) // 2] < 0.08, imu_ages[len(imu_ages) // 2]
    conflated = re.search(
        r'riverbridge_conflated_total\{[^}]*topic="/scan"[^}]*\} (\d+)', seen.metrics
    )
    assert conflated is not None and int(conflated.group(1)) == SCANS - len(seqs), seen.metrics
    goodput = re.search(r"riverbridge_client_goodput_bytes_per_second\{[^}]*\} (\S+)", seen.metrics)
    assert goodput is not None and 0.5e6 < float(goodput.group(1)) < 1.1e6  # 8 Mbit/s


async def test_without_queue_length_every_scan_arrives_in_order(bridge):
    async with LinkEmulator(LINK, ("127.0.0.1", bridge.port)) as link:
        seen = await subscribe_and_read(bridge, link, {}, until_scan=SCANS - 1)
    assert [seq for seq, _, _ in seen.scans] == list(range(SCANS))
    assert all(intact for _, _, intact in seen.scans)
    assert len(seen.imu) == int(SCANS * IMU_HZ / SCAN_HZ)


async def settle(ws: websockets.ClientConnection) -> None:
    """A rosapi round trip: every op sent before it has been handled."""
    await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/get_time", "id": "s"}))
    async with asyncio.timeout(10):
        while True:
            frame = await ws.recv()
            if isinstance(frame, str) and '"service_response"' in frame:
                return


async def fetch_metrics(port: int) -> str:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    writer.write(b"GET /metrics HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
    body = await reader.read()
    writer.close()
    return body.decode()
