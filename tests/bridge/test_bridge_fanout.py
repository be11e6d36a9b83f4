"""Fan-out over real sockets, on both event loops the bridge runs on (uvloop by default, asyncio
as the fallback): every reading subscriber gets every big and every small message, the same
bytes, in order per topic, while a subscriber that never reads holds nobody up; a burst of
small frames written in few transport writes arrives whole and in order."""

from __future__ import annotations

import asyncio
import json

import pytest
import websockets

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from schemas import codec_cbor
from schemas.runtime import event_loop

pytestmark = pytest.mark.timeout(120)

LOOPS = ["uvloop", "asyncio"]
READERS = 6
BIG_BYTES = 2 * 1024 * 1024  # each big message: a few socket buffers' worth
BIG_COUNT = 5
SMALL_PER_BIG = 10


async def connect(url: str) -> websockets.ClientConnection:
    return await websockets.connect(url, compression=None, max_size=None)


async def settle(ws: websockets.ClientConnection) -> None:
    """Round trip a rosapi call: every op sent before it has been handled."""
    await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/get_time", "id": "s"}))
    async with asyncio.timeout(30):
        while '"service_response"' not in str(await ws.recv()):
            pass


async def subscribe_both(ws: websockets.ClientConnection) -> None:
    for topic, type_name in (
        ("/big", "std_msgs/msg/UInt8MultiArray"),
        ("/small", "std_msgs/msg/String"),
    ):
        await ws.send(
            json.dumps(
                {"op": "subscribe", "topic": topic, "type": type_name, "compression": "cbor"}
            )
        )
    await settle(ws)


async def read_all(ws: websockets.ClientConnection) -> dict[str, list[object]]:
    """Every publish this subscriber gets until it has all of them: payloads per topic."""
    got: dict[str, list[object]] = {"/big": [], "/small": []}
    async with asyncio.timeout(90):
        while len(got["/big"]) < BIG_COUNT or len(got["/small"]) < BIG_COUNT * SMALL_PER_BIG:
            op = codec_cbor.loads(await ws.recv())
            msg = op["msg"]
            got[op["topic"]].append(msg["data"])
    return got


async def fan_out_scenario() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        readers = [await connect(bridge.url) for _ in range(READERS)]
        sleeper = await connect(bridge.url)  # subscribes, then never reads
        publisher = await connect(bridge.url)
        for ws in [*readers, sleeper]:
            await subscribe_both(ws)
        reading = [asyncio.create_task(read_all(ws)) for ws in readers]
        bigs = [bytes([k]) * BIG_BYTES for k in range(BIG_COUNT)]
        for k, big in enumerate(bigs):
            await publisher.send(
                codec_cbor.dumps({"op": "publish", "topic": "/big", "msg": {"data": big}})
            )
            for n in range(SMALL_PER_BIG):
                op = {"op": "publish", "topic": "/small", "msg": {"data": f"{k}.{n}"}}
                await publisher.send(codec_cbor.dumps(op))
        expected_small = [f"{k}.{n}" for k in range(BIG_COUNT) for n in range(SMALL_PER_BIG)]
        for got in await asyncio.gather(*reading):
            assert got["/small"] == expected_small
            assert got["/big"] == bigs
        for ws in [*readers, sleeper, publisher]:
            await ws.close()


@pytest.mark.parametrize("loop", LOOPS)
def test_every_reading_subscriber_gets_every_message_while_one_never_reads(loop: str) -> None:
    event_loop.run(fan_out_scenario(), loop)


async def burst_scenario(count: int) -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        subscriber, publisher = await connect(bridge.url), await connect(bridge.url)
        await subscriber.send(
            json.dumps({"op": "subscribe", "topic": "/chatter", "type": "std_msgs/msg/String"})
        )
        await settle(subscriber)
        for seq in range(count):  # one websocket message per publish, as fast as they go
            op = {"op": "publish", "topic": "/chatter", "msg": {"data": f"{seq} " + "x" * 90}}
            await publisher.send(json.dumps(op))
        seqs = []
        async with asyncio.timeout(60):
            while len(seqs) < count:
                op = json.loads(await subscriber.recv())
                seqs.append(int(op["msg"]["data"].split()[0]))
        assert seqs == list(range(count))
        await subscriber.close()
        await publisher.close()


@pytest.mark.parametrize("loop", LOOPS)
def test_a_burst_written_in_batches_arrives_whole_and_in_order(loop: str) -> None:
    event_loop.run(burst_scenario(5_000), loop)
