"""The bridge over real websockets: run_bridge on port 0 and `websockets` clients."""

from __future__ import annotations

import asyncio
import base64
import json
import os
import socket
import time
from collections.abc import AsyncIterator

import numpy as np
import pytest
import websockets
from websockets.exceptions import ConnectionClosed

from bridge.compose import RunningBridge, run_bridge
from bridge.config import BridgeConfig
from schemas import codec_cbor
from schemas.pointcloud import pack_points

pytestmark = pytest.mark.timeout(60)


@pytest.fixture
async def bridge(registry) -> AsyncIterator[RunningBridge]:
    async with run_bridge(BridgeConfig(port=0), registry) as running:
        yield running


def point_cloud(num_points: int, seed: int = 0) -> tuple[dict, bytes]:
    """A PointCloud2 of `num_points` xyz+intensity float32 points, and its raw data."""
    points = np.random.default_rng(seed).random((num_points, 4), dtype=np.float32)
    msg = pack_points(points, 1_000_000_002, "lidar")
    return msg, msg["data"]


def imu(seq: int) -> dict:
    return {
        "header": {"stamp": {"sec": seq, "nanosec": 0}, "frame_id": "imu"},
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        "angular_velocity": {"x": 0.1 * seq, "y": 0.0, "z": 0.0},
        "linear_acceleration_covariance": [0.5] * 9,
    }


def as_json(msg: dict) -> dict:
    return {k: base64.b64encode(v).decode() if isinstance(v, bytes) else v for k, v in msg.items()}


async def next_message(ws, op: str = "publish", timeout: float = 10.0) -> dict:
    """The next decoded message with the given op (text = JSON, binary = CBOR)."""
    async with asyncio.timeout(timeout):
        while True:
            frame = await ws.recv()
            message = json.loads(frame) if isinstance(frame, str) else codec_cbor.loads(frame)
            if message.get("op") == op:
                return message


async def settle(ws) -> None:
    """Round trip a rosapi call so every op sent before it has been handled."""
    await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/get_time", "id": "settle"}))
    await next_message(ws, "service_response")


async def test_pointcloud_and_imu_in_json_and_cbor(bridge):
    cloud, raw = point_cloud(65_536)
    async with (
        websockets.connect(bridge.url, max_size=None) as json_pub,
        websockets.connect(bridge.url, max_size=None) as cbor_pub,
        websockets.connect(bridge.url, max_size=None) as json_sub,
        websockets.connect(bridge.url, max_size=None) as cbor_sub,
    ):
        for topic, type_name in (
            ("/lidar", "sensor_msgs/PointCloud2"),
            ("/imu", "sensor_msgs/msg/Imu"),
        ):
            await json_sub.send(json.dumps({"op": "subscribe", "topic": topic, "type": type_name}))
            await cbor_sub.send(
                json.dumps({"op": "subscribe", "topic": topic, "compression": "cbor"})
            )
        await settle(json_sub)
        await settle(cbor_sub)
        await json_pub.send(json.dumps({"op": "publish", "topic": "/lidar", "msg": as_json(cloud)}))
        await cbor_pub.send(codec_cbor.dumps({"op": "publish", "topic": "/lidar", "msg": cloud}))
        for _ in range(2):
            from_json = await next_message(json_sub)
            assert base64.b64decode(from_json["msg"]["data"]) == raw
            assert from_json["msg"]["width"] == 65_536
            from_cbor = await next_message(cbor_sub)
            assert from_cbor["msg"]["data"] == raw
            assert from_cbor["msg"]["fields"][3]["name"] == "intensity"
        await cbor_pub.send(codec_cbor.dumps({"op": "publish", "topic": "/imu", "msg": imu(3)}))
        await json_pub.send(json.dumps({"op": "publish", "topic": "/imu", "msg": imu(4)}))
        for seq in (3, 4):
            got_json, got_cbor = await next_message(json_sub), await next_message(cbor_sub)
            assert got_json["msg"]["angular_velocity"]["x"] == pytest.approx(0.1 * seq)
            assert got_cbor["msg"]["linear_acceleration_covariance"] == [0.5] * 9
            assert got_cbor["msg"]["header"]["stamp"] == {"sec": seq, "nanosec": 0}


async def test_service_round_trip_between_two_clients(bridge):
    async with websockets.connect(bridge.url) as provider, websockets.connect(bridge.url) as caller:
        await provider.send(
            json.dumps(
                {
                    "op": "advertise_service",
                    "service": "/add",
                    "type": "example_interfaces/AddTwoInts",
                }
            )
        )
        await settle(provider)
        await caller.send(
            json.dumps(
                {"op": "call_service", "service": "/add", "id": "c", "args": {"a": 2, "b": 40}}
            )
        )
        request = await next_message(provider, "call_service")
        args = request["args"]
        await provider.send(
            json.dumps(
                {
                    "op": "service_response",
                    "service": "/add",
                    "id": request["id"],
                    "result": True,
                    "values": {"sum": args["a"] + args["b"]},
                }
            )
        )
        response = await next_message(caller, "service_response")
        assert response == {
            "op": "service_response",
            "service": "/add",
            "values": {"sum": 42},
            "result": True,
            "id": "c",
        }


async def test_disconnect_cleans_up_everything_the_client_owned(bridge):
    async with websockets.connect(bridge.url) as watcher:
        async with websockets.connect(bridge.url) as owner:
            await owner.send(
                json.dumps({"op": "advertise", "topic": "/t", "type": "std_msgs/String"})
            )
            await owner.send(
                json.dumps({"op": "subscribe", "topic": "/u", "type": "std_msgs/Int32"})
            )
            await owner.send(
                json.dumps({"op": "advertise_service", "service": "/s", "type": "std_srvs/Trigger"})
            )
            await owner.send(
                json.dumps({"op": "fragment", "id": 1, "num": 0, "total": 2, "data": "{"})
            )
            await settle(owner)
            await watcher.send(json.dumps({"op": "call_service", "service": "/s", "id": 1}))
            await next_message(owner, "call_service")
        failed = await next_message(watcher, "service_response")
        assert failed["result"] is False
        await watcher.send(json.dumps({"op": "call_service", "service": "/rosapi/topics"}))
        topics = (await next_message(watcher, "service_response"))["values"]["topics"]
        assert topics == ["/rosout"]
        state = bridge.core.state
        assert len(state.sessions) == 1 and state.pending_calls == {}
        assert state.graph.services == {} and state.topic_subscriptions == {}


async def test_oversize_frame_closes_1009_while_others_keep_receiving(registry):
    config = BridgeConfig(port=0, max_message_size=256 * 1024)
    async with (
        run_bridge(config, registry) as bridge,
        websockets.connect(bridge.url) as pub,
        websockets.connect(bridge.url) as sub,
        websockets.connect(bridge.url, max_size=None) as offender,
    ):
        await sub.send(json.dumps({"op": "subscribe", "topic": "/c", "type": "std_msgs/String"}))
        await settle(sub)
        await offender.send("x" * (512 * 1024))
        with pytest.raises(ConnectionClosed) as closed:
            await offender.recv()
        assert closed.value.rcvd.code == 1009
        await pub.send(json.dumps({"op": "publish", "topic": "/c", "msg": {"data": "alive"}}))
        assert (await next_message(sub))["msg"]["data"] == "alive"


async def test_fragments_cannot_get_around_the_size_limit(registry):
    config = BridgeConfig(port=0, max_message_size=4096)
    async with run_bridge(config, registry) as bridge, websockets.connect(bridge.url) as offender:
        for frag_id in range(3):
            await offender.send(
                json.dumps(
                    {"op": "fragment", "id": frag_id, "num": 0, "total": 2, "data": "x" * 2000}
                )
            )
        with pytest.raises(ConnectionClosed) as closed:
            await offender.recv()
        assert closed.value.rcvd.code == 1009


async def test_slow_reader_does_not_stall_a_fast_one(registry):
    config = BridgeConfig(port=0, send_buffer_bytes=1024 * 1024)
    cloud, _ = point_cloud(32_768)
    async with (
        run_bridge(config, registry) as bridge,
        websockets.connect(bridge.url, max_size=None) as pub,
        websockets.connect(bridge.url, max_size=None) as fast,
        websockets.connect(bridge.url, max_size=None, max_queue=1) as slow,
    ):
        for client in (fast, slow):
            await client.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "topic": "/lidar",
                        "compression": "cbor",
                        "type": "sensor_msgs/PointCloud2",
                    }
                )
            )
        await fast.send(json.dumps({"op": "subscribe", "topic": "/imu", "type": "sensor_msgs/Imu"}))
        await settle(fast)
        await settle(slow)
        count = 60
        received: list[int] = []

        async def read_imu() -> None:
            while len(received) < count:
                message = await next_message(fast)
                if message["topic"] == "/imu":
                    received.append(message["msg"]["header"]["stamp"]["sec"])

        reader = asyncio.create_task(read_imu())
        started = time.monotonic()
        for seq in range(count):
            await pub.send(codec_cbor.dumps({"op": "publish", "topic": "/lidar", "msg": cloud}))
            await pub.send(json.dumps({"op": "publish", "topic": "/imu", "msg": imu(seq)}))
            await asyncio.sleep(0.005)
        await asyncio.wait_for(reader, 30)
        assert received == list(range(count))
        assert time.monotonic() - started < 30
        stats = bridge.server.stats()
        assert sum(sum(client["dropped"].values()) for client in stats.values()) > 0
        assert all(not client["dropped"].get("/imu") for client in stats.values())
        slow.transport.abort()  # a stalled reader cannot take part in a closing handshake


async def stalled_client(port: int) -> tuple[asyncio.StreamWriter, socket.socket]:
    """A websocket client that completes the handshake and then never reads again."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    sock = writer.get_extra_info("socket")
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    key = base64.b64encode(os.urandom(16)).decode()
    writer.write(
        f"GET / HTTP/1.1\r\nHost: localhost\r\nUpgrade: websocket\r\n"
        f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
        f"Sec-WebSocket-Version: 13\r\n\r\n".encode()
    )
    await reader.readuntil(b"\r\n\r\n")
    return writer, sock


def masked_text_frame(text: str) -> bytes:
    """A client text frame with an all-zero mask key (so the payload is sent as is)."""
    payload = text.encode()
    assert len(payload) < 126
    return bytes([0x81, 0x80 | len(payload)]) + bytes(4) + payload


async def test_client_that_never_reads_its_answers_is_paused_not_buffered(bridge):
    from bridge.server import ANSWER_BACKLOG

    writer, _ = await stalled_client(bridge.port)
    call = masked_text_frame(
        json.dumps({"op": "call_service", "id": 1, "service": "/rosapi/interfaces"})
    )
    writer.write(call * 5000)  # ~50 MB of answers if the bridge answered them all
    async with websockets.connect(bridge.url) as other:
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            backlog = max(link.queue.answers_waiting for link in bridge.server.links.values())
            if backlog >= ANSWER_BACKLOG:
                break
            await asyncio.sleep(0.05)
        await asyncio.sleep(0.3)
        backlog = max(link.queue.answers_waiting for link in bridge.server.links.values())
        assert ANSWER_BACKLOG <= backlog <= ANSWER_BACKLOG + 1
        await settle(other)
    writer.transport.abort()


async def test_shutdown_is_prompt_with_a_stalled_client(registry):
    call = masked_text_frame(
        json.dumps({"op": "call_service", "id": 1, "service": "/rosapi/interfaces"})
    )
    started = time.monotonic()
    async with run_bridge(BridgeConfig(port=0), registry) as bridge:
        writer, _ = await stalled_client(bridge.port)
        writer.write(call * 2000)
        await asyncio.sleep(0.5)
    assert time.monotonic() - started < 10
    writer.transport.abort()


async def test_version_endpoint_and_plain_http(bridge):
    async def get(path: str) -> bytes:
        reader, writer = await asyncio.open_connection("127.0.0.1", bridge.port)
        writer.write(f"GET {path} HTTP/1.1\r\nHost: localhost\r\n\r\n".encode())
        await writer.drain()
        data = await asyncio.wait_for(reader.read(), 5)
        writer.close()
        return data

    head, _, body = (await get("/version")).partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 200") and b"application/json" in head
    version = json.loads(body)
    assert version["protocol"]["major"] == 2 and version["server"].startswith("riverbridge")
    assert (await get("/")).startswith(b"HTTP/1.1 200")
    assert (await get("/elsewhere")).startswith(b"HTTP/1.1 404")


async def test_garbage_from_one_client_never_disturbs_another(bridge):
    async with (
        websockets.connect(bridge.url) as pub,
        websockets.connect(bridge.url) as sub,
        websockets.connect(bridge.url) as vandal,
    ):
        await sub.send(json.dumps({"op": "subscribe", "topic": "/c", "type": "std_msgs/String"}))
        await settle(sub)
        for junk in (
            "{",
            "42",
            "null",
            "[]",
            '"op"',
            b"\xff\x00\x13",
            b'{"op": 1}',
            json.dumps({"op": "publish", "topic": 5}),
            json.dumps({"op": "subscribe", "topic": "/c", "throttle_rate": "fast"}),
        ):
            await vandal.send(junk)
        await settle(vandal)
        await pub.send(json.dumps({"op": "publish", "topic": "/c", "msg": {"data": "ok"}}))
        assert (await next_message(sub))["msg"]["data"] == "ok"
