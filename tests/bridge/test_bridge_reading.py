"""The inbound data path (`bridge.reading`) over real sockets: messages from websockets' parser
straight to the bridge behave as `recv()` delivered them: fragmented messages are joined, text
must be UTF-8 (1007), oversize messages and too many fragments close with 1009, a client's
last messages before it closes are still handled, and a client that sends thousands of
messages in one write gets each handled once, in order."""

from __future__ import annotations

import asyncio
import json

import pytest
import websockets
from websockets.asyncio.messages import MAX_FRAGMENTS
from websockets.exceptions import ConnectionClosed

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from schemas import codec_cbor

pytestmark = pytest.mark.timeout(60)

TOPIC, TYPE = "/chatter", "std_msgs/msg/String"


async def connect(url: str) -> websockets.ClientConnection:
    return await websockets.connect(url, compression=None, max_size=None)


async def subscriber(url: str, compression: str = "none") -> websockets.ClientConnection:
    """A client subscribed to TOPIC, once the bridge has handled its subscribe."""
    ws = await connect(url)
    op = {"op": "subscribe", "topic": TOPIC, "type": TYPE, "compression": compression}
    await ws.send(json.dumps(op))
    await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/get_time", "id": "s"}))
    async with asyncio.timeout(10):
        while '"service_response"' not in str(await ws.recv()):
            pass
    return ws


def publish(data: str) -> str:
    return json.dumps({"op": "publish", "topic": TOPIC, "msg": {"data": data}})


async def next_data(ws: websockets.ClientConnection) -> str:
    async with asyncio.timeout(10):
        frame = await ws.recv()
    op = json.loads(frame) if isinstance(frame, str) else codec_cbor.loads(frame)
    data: str = op["msg"]["data"]
    return data


async def closed_with(ws: websockets.ClientConnection) -> int | None:
    """The close code the bridge sent once it closed `ws`."""
    async with asyncio.timeout(10):
        with pytest.raises(ConnectionClosed):
            while True:
                await ws.recv()
    return ws.close_code


async def test_fragmented_text_and_binary_messages_are_joined() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        pub = await connect(bridge.url)
        text = publish("joined " + "t" * 3000)
        await pub.send([text[i : i + 100] for i in range(0, len(text), 100)])  # 31 frames
        assert await next_data(sub) == "joined " + "t" * 3000
        binary = codec_cbor.dumps({"op": "publish", "topic": TOPIC, "msg": {"data": "cbor"}})
        await pub.send([binary[:7], binary[7:20], binary[20:]])
        assert await next_data(sub) == "cbor"
        await pub.send(publish("after"))  # the connection goes on as before
        assert await next_data(sub) == "after"


async def test_invalid_utf8_in_a_text_frame_closes_with_1007() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        pub = await connect(bridge.url)
        bad = b'{"op": "publish", "topic": "/chatter", "msg": {"data": "\xff"}}'
        await pub.send(bad, text=True)
        assert await closed_with(pub) == 1007
        other = await connect(bridge.url)  # the bridge and its other clients go on
        await other.send(publish("still here"))
        assert await next_data(sub) == "still here"


async def test_oversize_messages_close_with_1009_whole_or_fragmented() -> None:
    async with run_bridge(BridgeConfig(port=0, max_message_size=4096)) as bridge:
        sub = await subscriber(bridge.url)
        whole = await connect(bridge.url)
        await whole.send(publish("x" * 5000))
        assert await closed_with(whole) == 1009
        pieces = await connect(bridge.url)
        await pieces.send(["x" * 1000] * 5)  # each fragment fits, the message does not
        assert await closed_with(pieces) == 1009
        fits = await connect(bridge.url)
        await fits.send(publish("y" * 3000))
        assert await next_data(sub) == "y" * 3000


async def test_too_many_fragments_close_with_1009() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        pub = await connect(bridge.url)
        await pub.send(["x"] * (MAX_FRAGMENTS + 1))
        assert await closed_with(pub) == 1009


async def test_messages_sent_just_before_closing_are_handled() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        pub = await connect(bridge.url)
        for n in range(50):
            await pub.send(publish(f"last {n}"))
        await pub.close()
        assert [await next_data(sub) for _ in range(50)] == [f"last {n}" for n in range(50)]


async def test_thousands_of_messages_in_one_write_are_each_handled_once_in_order() -> None:
    """One socket write holds 3,000 publishes: far more than one turn (`TURN_S`) handles, so
    the reader pauses and goes on several times; CBOR for the subscriber."""
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url, "cbor")
        pub = await connect(bridge.url)
        count = 3000
        async with pub.send_context():  # frame them all, then write them at once
            for n in range(count):
                pub.protocol.send_text(publish(f"{n} " + "x" * 80).encode())
        got = [await next_data(sub) for _ in range(count)]
        assert [int(data.split()[0]) for data in got] == list(range(count))
