"""The link frames outgoing messages itself (`bridge.link.frame_header`): byte for byte what
websockets would have written, and read back by a real websockets client at every length
class (7-bit, 16-bit and 64-bit lengths, joined small writes and separate large ones)."""

from __future__ import annotations

import asyncio
import json

import pytest
import websockets
from websockets.frames import Frame, Opcode

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from bridge.link import JOIN_LIMIT, frame_header
from schemas import codec_cbor

pytestmark = pytest.mark.timeout(60)

SIZES = [0, 1, 125, 126, 127, 65535, 65536, 65537, JOIN_LIMIT - 1, JOIN_LIMIT, 3_000_000]


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("text", [True, False])
def test_header_and_payload_are_what_websockets_serializes(size: int, text: bool) -> None:
    payload = bytes(range(256)) * (size // 256) + bytes(size % 256)
    opcode = Opcode.TEXT if text else Opcode.BINARY
    assert frame_header(text, size) + payload == Frame(opcode, payload).serialize(mask=False)


@pytest.mark.parametrize("compression", ["none", "cbor"])
async def test_a_websockets_client_reads_every_length_class(registry, compression: str) -> None:
    lengths = [*range(90, 140), *range(65_440, 65_560, 3), JOIN_LIMIT + 5, 1_000_000]
    async with run_bridge(BridgeConfig(port=0), registry) as bridge:
        url = f"ws://127.0.0.1:{bridge.port}"
        async with websockets.connect(url, max_size=None) as sub, websockets.connect(url) as pub:
            await sub.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "topic": "/sized",
                        "type": "std_msgs/msg/String",
                        "compression": compression,
                    }
                )
            )
            await pub.send(
                json.dumps({"op": "advertise", "topic": "/sized", "type": "std_msgs/msg/String"})
            )
            await sub.send(json.dumps({"op": "call_service", "service": "/rosapi/get_time"}))
            assert "service_response" in await asyncio.wait_for(sub.recv(), 10)  # subscribed
            for n in lengths:
                await pub.send(
                    json.dumps({"op": "publish", "topic": "/sized", "msg": {"data": "x" * n}})
                )
            got = []
            while len(got) < len(lengths):
                frame = await asyncio.wait_for(sub.recv(), 10)
                assert isinstance(frame, str) == (compression == "none")
                msg = json.loads(frame) if isinstance(frame, str) else codec_cbor.loads(frame)
                got.append(len(msg["msg"]["data"]))
            assert got == lengths
