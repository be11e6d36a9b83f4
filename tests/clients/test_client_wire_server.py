"""What the real bridge never sends: garbage, fragments, png, huge frames, abrupt closes.

A small scripted websockets server (port 0) plays rosbridge_suite's quirks the riverbridge
bridge does not have, so the client's receive pump is tested over a real socket.
"""

from __future__ import annotations

import asyncio
import base64

import orjson
import websockets

from clients import RosbridgeClient
from tests.clients.client_messages import (
    pointcloud,
    publish_text,
    rosbridge_fragments,
    rosbridge_png,
)


class ScriptedServer:
    """Records every op a client sends; on each ``subscribe`` plays ``script`` to it."""

    def __init__(self, script: list[str | bytes], *, close_after_first: bool = False) -> None:
        self.script = script
        self.close_after_first = close_after_first
        self.ops: list[dict] = []
        self.connections = 0

    async def handler(self, ws) -> None:
        self.connections += 1
        async for data in ws:
            op = orjson.loads(data)
            self.ops.append(op)
            if op["op"] != "subscribe":
                continue
            for frame in self.script:
                await ws.send(frame)
            if self.close_after_first and self.connections == 1:
                await ws.close()
                return


async def serve(server: ScriptedServer):
    return await websockets.serve(server.handler, "127.0.0.1", 0, compression=None, max_size=None)


async def test_pump_survives_garbage_and_decodes_quirky_frames(registry):
    cloud = pointcloud(registry, 40_000)  # 640 kB: JSON over the offload threshold
    big = orjson.dumps(
        {
            "op": "publish",
            "topic": "/t",
            "msg": {
                **{k: v for k, v in cloud.items() if k != "data"},
                "data": base64.b64encode(cloud["data"]).decode(),
            },
        }
    ).decode()
    script = [
        "this is not json",
        publish_text("/t", b"\x01" * 32),
        b"\xff\xfe garbage",
        *rosbridge_fragments(publish_text("/t", b"\x02" * 64), size=50),
        rosbridge_png(publish_text("/t", b"\x03" * 16)).decode(),
        big,
        publish_text("/t", b"\x04" * 8),
    ]
    server = ScriptedServer(script)
    async with await serve(server) as ws_server:
        port = ws_server.sockets[0].getsockname()[1]
        async with RosbridgeClient(
            f"ws://127.0.0.1:{port}", encoding="json", registry=registry
        ) as client:
            sub = await client.subscribe("/t", "sensor_msgs/msg/PointCloud2")
            got = [await asyncio.wait_for(sub.get(), 5) for _ in range(5)]
            assert client.bad_frames == 2
    small = [item.msg["data"] for item in got if item.msg["width"] != cloud["width"]]
    assert small == [b"\x01" * 32, b"\x02" * 64, b"\x03" * 16, b"\x04" * 8]
    [whole] = [item for item in got if item.msg["width"] == cloud["width"]]
    assert whole.msg["data"] == cloud["data"]
    assert whole.wire_bytes == len(big)
    assert server.ops[0]["op"] == "subscribe" and server.ops[0]["type"].endswith("PointCloud2")


async def test_resubscribes_with_the_same_id_after_an_abrupt_close(registry):
    server = ScriptedServer([publish_text("/t", b"\x05" * 16)], close_after_first=True)
    async with await serve(server) as ws_server:
        port = ws_server.sockets[0].getsockname()[1]
        async with RosbridgeClient(
            f"ws://127.0.0.1:{port}", encoding="cbor", registry=registry, backoff_max=0.2
        ) as client:
            await client.advertise("/out", "std_msgs/msg/String", latch=True)
            sub = await client.subscribe("/t", "sensor_msgs/msg/PointCloud2")
            first = await asyncio.wait_for(sub.get(), 5)
            second = await asyncio.wait_for(sub.get(), 5)
            assert client.connections == 2
    assert first.msg["data"] == second.msg["data"] == b"\x05" * 16
    subscribes = [op for op in server.ops if op["op"] == "subscribe"]
    adverts = [op for op in server.ops if op["op"] == "advertise"]
    assert len(subscribes) == 2 and subscribes[0]["id"] == subscribes[1]["id"]
    assert subscribes[1]["compression"] == "cbor"
    assert len(adverts) == 2 and adverts[1]["latch"] is True
    assert adverts[0]["id"] == adverts[1]["id"]
