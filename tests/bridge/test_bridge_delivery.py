"""Delivery semantics over real sockets (docs/bridge.md, "Delivery"): a reader loses nothing,
a client that stops reading loses its oldest (counted) and nobody else does, order per topic."""

from __future__ import annotations

import asyncio
import json
import socket
import time
from collections.abc import AsyncIterator

import pytest
import websockets

from bridge.compose import RunningBridge, run_bridge
from bridge.config import BridgeConfig
from bridge.problems import LINES_PER_WINDOW
from schemas import codec_cbor

pytestmark = pytest.mark.timeout(90)

BURST = 20_000


@pytest.fixture
async def bridge(registry) -> AsyncIterator[RunningBridge]:
    async with run_bridge(BridgeConfig(port=0), registry) as running:
        yield running


async def settle(ws) -> None:
    """Round trip a rosapi call: every op sent before it has been handled."""
    await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/get_time", "id": "s"}))
    while True:
        frame = await asyncio.wait_for(ws.recv(), 10)
        if isinstance(frame, str) and '"service_response"' in frame:
            return


async def subscribe(ws, topic: str, type_name: str, compression: str = "none") -> None:
    await ws.send(
        json.dumps(
            {"op": "subscribe", "topic": topic, "type": type_name, "compression": compression}
        )
    )
    await settle(ws)


def decode(frame: bytes | str) -> dict:
    return json.loads(frame) if isinstance(frame, str) else codec_cbor.loads(frame)


async def read_publishes(ws, count: int, timeout: float = 60) -> list[dict]:
    """The next `count` publish ops arriving on `ws`."""
    got: list[dict] = []
    async with asyncio.timeout(timeout):
        while len(got) < count:
            message = decode(await ws.recv())
            if message.get("op") == "publish":
                got.append(message)
    return got


async def publish_numbered(ws, count: int, pad: int = 80, binary: bool = False) -> None:
    """`count` std_msgs/String on /chatter, as fast as the connection takes them."""
    filler = "x" * pad
    for seq in range(count):
        op = {"op": "publish", "topic": "/chatter", "msg": {"data": f"{seq} {filler}"}}
        await ws.send(codec_cbor.dumps(op) if binary else json.dumps(op))


def seq_of(message: dict) -> int:
    return int(message["msg"]["data"].split()[0])


@pytest.mark.parametrize("binary", [False, True], ids=["json", "cbor"])
async def test_a_reading_subscriber_loses_none_of_a_20000_burst(bridge, binary):
    async with (
        websockets.connect(bridge.url) as pub,
        websockets.connect(bridge.url, max_size=None) as sub,
    ):
        await subscribe(sub, "/chatter", "std_msgs/msg/String", "cbor" if binary else "none")
        await pub.send(
            json.dumps({"op": "advertise", "topic": "/chatter", "type": "std_msgs/msg/String"})
        )
        reader = asyncio.create_task(read_publishes(sub, BURST))
        await publish_numbered(pub, BURST, binary=binary)
        got = await reader
    assert [seq_of(m) for m in got] == list(range(BURST))
    assert not any(client["dropped"] for client in bridge.server.stats().values())


async def stalled_subscriber(url: str, topic: str) -> websockets.ClientConnection:
    """A subscriber whose socket takes almost nothing until it calls recv(): a 4 KiB receive
    buffer and a one-frame queue in websockets."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    host, port = url.removeprefix("ws://").split(":")
    sock.connect((host, int(port)))
    sock.setblocking(False)
    ws = await websockets.connect(url, sock=sock, max_queue=1, max_size=None)
    await subscribe(ws, topic, "std_msgs/msg/String")
    return ws


async def test_a_client_that_stops_reading_loses_its_oldest_counted_and_nobody_else_does(registry):
    limit = 256 * 1024
    async with (
        run_bridge(BridgeConfig(port=0, send_buffer_bytes=limit), registry) as bridge,
        websockets.connect(bridge.url) as pub,
        websockets.connect(bridge.url, max_size=None) as reader,
    ):
        stalled = await stalled_subscriber(bridge.url, "/chatter")
        await subscribe(reader, "/chatter", "std_msgs/msg/String")
        reading = asyncio.create_task(read_publishes(reader, BURST))
        await publish_numbered(pub, BURST, pad=1000)  # ~20 MB, far past every buffer
        got = await reading
        assert [seq_of(m) for m in got] == list(range(BURST))
        await settle(pub)
        stats = bridge.server.stats()
        stalled_stats = max(stats.values(), key=lambda client: client["backlog_bytes"])
        dropped = stalled_stats["dropped"].get("/chatter", 0)
        assert dropped > 0
        assert stalled_stats["backlog_bytes"] <= limit + 2048  # the bound, plus one message
        assert sum(sum(client["dropped"].values()) for client in stats.values()) == dropped

        # Reading again, it gets everything still waiting: increasing, ending with the newest
        # message; the gaps are exactly the dropped count.
        seqs = [seq_of(m) for m in await read_publishes(stalled, BURST - dropped)]
        assert seqs == sorted(seqs) and seqs[-1] == BURST - 1
        assert len(seqs) + dropped == BURST
        await stalled.close()


async def test_a_slow_reader_paces_the_publisher_and_loses_nothing(registry):
    """2 MB through a 256 KiB bound and small socket buffers to a subscriber that reads at most
    10,000 msg/s: the publisher is slowed (TCP), the subscriber gets everything (well within
    the 2 s a subscriber may stay backed up before it counts as slow, even on a busy
    machine)."""
    count = 2_000
    async with (
        run_bridge(BridgeConfig(port=0, send_buffer_bytes=256 * 1024), registry) as bridge,
        websockets.connect(bridge.url) as pub,
    ):
        slow = await stalled_subscriber(bridge.url, "/chatter")
        for link in bridge.server.links.values():  # a thin pipe: the kernel buffers little
            link.ws.transport.get_extra_info("socket").setsockopt(
                socket.SOL_SOCKET, socket.SO_SNDBUF, 4096
            )

        async def read_slowly() -> list[int]:
            seqs: list[int] = []
            while len(seqs) < count:
                seqs += [seq_of(m) for m in await read_publishes(slow, 10, timeout=10)]
                await asyncio.sleep(0.001)
            return seqs

        reading = asyncio.create_task(read_slowly())
        await publish_numbered(pub, count, pad=1000)
        assert await reading == list(range(count))
        assert not any(client["dropped"] for client in bridge.server.stats().values())
        await slow.close()


async def test_order_per_topic_holds_and_other_topics_overtake_a_big_frame(bridge):
    """A MarkerArray of 3,000 markers takes the worker tens of ms to validate (and, for the
    JSON subscriber, to encode): small frames sent after it on the same connection overtake it
    on another topic and wait for it on its own topic."""
    markers = {
        "markers": [
            {
                "header": {"frame_id": "map"},
                "ns": "n",
                "id": i,
                "pose": {"position": {"x": float(i)}},
            }
            for i in range(3_000)
        ]
    }
    async with (
        websockets.connect(bridge.url, max_size=None) as pub,
        websockets.connect(bridge.url, max_size=None) as sub,
    ):
        for topic, type_name in (
            ("/big", "visualization_msgs/msg/MarkerArray"),
            ("/small", "std_msgs/msg/String"),
        ):
            await subscribe(sub, topic, type_name)
            await pub.send(json.dumps({"op": "advertise", "topic": topic, "type": type_name}))
        await settle(pub)
        await pub.send(json.dumps({"op": "publish", "topic": "/big", "msg": markers}))
        for n in range(3):
            await pub.send(
                json.dumps({"op": "publish", "topic": "/small", "msg": {"data": str(n)}})
            )
        await pub.send(json.dumps({"op": "publish", "topic": "/big", "msg": {"markers": []}}))
        got = await read_publishes(sub, 5)
    order = [
        (m["topic"], len(m["msg"]["markers"]) if m["topic"] == "/big" else m["msg"]["data"])
        for m in got
    ]
    assert order.index(("/small", "0")) < order.index(("/big", 3_000))  # overtaken
    assert [o for o in order if o[0] == "/small"] == [("/small", str(n)) for n in range(3)]
    assert [o for o in order if o[0] == "/big"] == [("/big", 3_000), ("/big", 0)]  # in order


async def next_reassembled(ws, pieces: dict[str, dict[int, str]]) -> dict:
    """Read `fragment` ops until one message is complete; return it."""
    while True:
        fragment = json.loads(await asyncio.wait_for(ws.recv(), 10))
        assert fragment["op"] == "fragment"
        got = pieces.setdefault(fragment["id"], {})
        assert fragment["num"] not in got  # an id is never reused while incomplete
        got[fragment["num"]] = fragment["data"]
        if len(got) == fragment["total"]:
            return json.loads("".join(got[n] for n in range(fragment["total"])))


async def test_back_to_back_messages_are_fragmented_under_distinct_ids(bridge):
    async with websockets.connect(bridge.url) as pub, websockets.connect(bridge.url) as sub:
        await sub.send(
            json.dumps(
                {
                    "op": "subscribe",
                    "topic": "/chatter",
                    "type": "std_msgs/msg/String",
                    "fragment_size": 1000,
                }
            )
        )
        await settle(sub)  # the answer is shorter than a fragment
        texts = [f"{n} " + "y" * 2500 for n in range(3)]
        for text in texts:
            await pub.send(
                json.dumps({"op": "publish", "topic": "/chatter", "msg": {"data": text}})
            )
        pieces: dict[str, dict[int, str]] = {}
        got = [await next_reassembled(sub, pieces) for _ in texts]
    assert [m["msg"]["data"] for m in got] == texts
    assert len(pieces) == 3


FLOOD = 1000


@pytest.mark.parametrize("offload_bytes", [1 << 30, 1], ids=["inline", "worker"])
async def test_a_flood_of_unencodable_messages_logs_a_few_lines_and_costs_nothing_else(
    registry, caplog, offload_bytes
):
    """A source hands the bridge messages that have no CDR (a lone surrogate has no UTF-8): each is
    lost alone, the log gets at most `LINES_PER_WINDOW` one-line errors and a summary, and the
    same client's other topic and another client receive every message."""
    config = BridgeConfig(port=0, offload_threshold_bytes=offload_bytes)
    async with (
        run_bridge(config, registry) as bridge,
        websockets.connect(bridge.url, max_size=None) as plain,
    ):
        await subscribe(plain, "/chatter", "std_msgs/msg/String")
        async with websockets.connect(bridge.url, max_size=None) as raw:
            await subscribe(raw, "/odd", "std_msgs/msg/String", "cbor-raw")
            await subscribe(raw, "/chatter", "std_msgs/msg/String", "cbor-raw")
            readers = [asyncio.create_task(read_publishes(ws, FLOOD)) for ws in (raw, plain)]
            for seq in range(FLOOD):
                now_ns = time.time_ns()
                bridge.server.apply(
                    bridge.core.publish_external(
                        "/source", "/odd", "std_msgs/msg/String", {"data": "odd\ud800"}, now_ns
                    )
                )
                bridge.server.apply(
                    bridge.core.publish_external(
                        "/source", "/chatter", "std_msgs/msg/String", {"data": f"{seq}"}, now_ns
                    )
                )
                if seq % 100 == 0:
                    await asyncio.sleep(0)
            got_raw, got_plain = await asyncio.gather(*readers)
            await settle(raw)  # the connection itself is untouched
        await settle(plain)
    assert [m["topic"] for m in got_raw] == ["/chatter"] * FLOOD
    assert [int(m["msg"]["data"]) for m in got_plain] == list(range(FLOOD))
    lines = [r for r in caplog.records if "cannot encode a message for /odd" in r.getMessage()]
    assert 1 <= len(lines) <= LINES_PER_WINDOW
    assert all(r.exc_info is None and "\n" not in r.getMessage() for r in lines)
    assert "surrogates not allowed" in lines[0].getMessage()
    summaries = [r.getMessage() for r in caplog.records if "unencodable" in r.getMessage()]
    assert len(summaries) == 1 and f"{FLOOD:,} unencodable messages" in summaries[0]
    assert f"{FLOOD - len(lines):,} not logged" in summaries[0]
    assert len(caplog.text) < 20_000
