"""Foxglove clients go through the rosbridge side's door and send queue: TLS, the Origin
allow-list, authentication, and a bounded queue that drops a non-reader's oldest messages,
while a rosbridge client on the same port reads everything."""

from __future__ import annotations

import asyncio
import contextlib
import json
import ssl
import time
from pathlib import Path
from typing import Any

import orjson
import pytest
import websockets
from pydantic import SecretStr
from websockets.exceptions import InvalidStatus

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from schemas.roles_config import load_roles
from schemas.tokens import issue
from tests.child_process import REPO_ROOT
from tests.tls_certificates import make_certificate

pytestmark = pytest.mark.timeout(60)

FOXGLOVE = "foxglove.websocket.v1"
SECRET = "s3cret-for-the-foxglove-tests"
WRENCH = "geometry_msgs/msg/Wrench"


async def next_json(ws: Any, op: str) -> dict[str, Any]:
    """The next text frame whose op is `op` (skipping others)."""
    while True:
        data = await asyncio.wait_for(ws.recv(), 10)
        if isinstance(data, str) and (message := json.loads(data))["op"] == op:
            return message


async def test_foxglove_over_tls(tmp_path: Path) -> None:
    pair = make_certificate(tmp_path)
    config = BridgeConfig(port=0, certfile=pair.certfile, keyfile=pair.keyfile)
    trust = ssl.create_default_context(cafile=str(pair.certfile))
    async with (
        run_bridge(config) as bridge,
        websockets.connect(bridge.url, subprotocols=[FOXGLOVE], ssl=trust) as ws,
    ):
        assert bridge.url.startswith("wss://")
        assert ws.subprotocol == FOXGLOVE
        assert (await next_json(ws, "serverInfo"))["name"] == "riverbridge"


async def test_a_refused_origin_is_refused_for_foxglove_too() -> None:
    config = BridgeConfig(port=0, allowed_origins=("https://app.example",))
    async with run_bridge(config) as bridge:
        with pytest.raises(InvalidStatus) as refused:
            async with websockets.connect(
                bridge.url, subprotocols=[FOXGLOVE], origin="https://evil.example"
            ):
                pass
        assert refused.value.response.status_code == 403
        async with websockets.connect(
            bridge.url, subprotocols=[FOXGLOVE], origin="https://app.example"
        ) as ws:
            assert ws.subprotocol == FOXGLOVE


async def test_the_client_limit_counts_foxglove_clients() -> None:
    async with (
        run_bridge(BridgeConfig(port=0, max_clients=1)) as bridge,
        websockets.connect(bridge.url, subprotocols=[FOXGLOVE]),
    ):
        with pytest.raises(InvalidStatus) as refused:
            async with websockets.connect(bridge.url):
                pass
        assert refused.value.response.status_code == 503


async def test_a_foxglove_client_without_a_token_may_do_nothing() -> None:
    config = BridgeConfig(port=0, auth_secret=SecretStr(SECRET))
    async with (
        run_bridge(config) as bridge,
        websockets.connect(bridge.url, subprotocols=[FOXGLOVE]) as ws,
    ):
        channels = (await next_json(ws, "advertise"))["channels"]
        rosout = next(c for c in channels if c["topic"] == "/rosout")
        request = {"op": "subscribe", "subscriptions": [{"id": 1, "channelId": rosout["id"]}]}
        await ws.send(orjson.dumps(request).decode())
        status = await next_json(ws, "status")
        assert status["level"] == 2 and "not authenticated" in status["message"]


async def test_a_foxglove_client_gets_the_rights_of_its_tokens_role() -> None:
    """The roles every rosbridge op passes: an observer's token (in the URL, as a browser
    app sends it) lets it subscribe and read parameters, not publish or set them."""
    roles = load_roles(REPO_ROOT / "config" / "roles.example.toml")
    config = BridgeConfig(port=0, auth_secret=SecretStr(SECRET), roles=roles)
    token = issue(SECRET, "observer", "foxglove-test", time.time(), 60.0)
    async with (
        run_bridge(config) as bridge,
        websockets.connect(f"{bridge.url}/?token={token}", subprotocols=[FOXGLOVE]) as ws,
    ):
        channels = (await next_json(ws, "advertise"))["channels"]
        rosout = next(c for c in channels if c["topic"] == "/rosout")
        frames = [
            {"op": "subscribe", "subscriptions": [{"id": 1, "channelId": rosout["id"]}]},
            {"op": "getParameters", "parameterNames": ["/a:b"], "id": "g"},
            {"op": "setParameters", "parameters": [{"name": "/a:b", "value": 1}], "id": "s"},
            {
                "op": "advertise",
                "channels": [
                    {"id": 1, "topic": "/cmd_wrench", "encoding": "cdr", "schemaName": WRENCH}
                ],
            },
        ]
        for frame in frames:
            await ws.send(orjson.dumps(frame).decode())
        assert (await next_json(ws, "parameterValues"))["id"] == "g"
        refusals = [(await next_json(ws, "status"))["message"] for _ in range(2)]
        assert refusals == [
            "set_param /a:b: role observer may not set param /a:b",
            "publish /cmd_wrench: role observer may not publish /cmd_wrench",
        ]
        session = next(iter(bridge.core.state.sessions.values()))
        assert "/rosout" in session.subscriptions  # the subscription was allowed


async def test_a_foxglove_client_that_stops_reading_loses_its_oldest(tmp_path: Path) -> None:
    config = BridgeConfig(port=0, send_buffer_bytes=4 * 1024 * 1024)
    payload = {"data": "x" * 100_000}
    async with (
        run_bridge(config) as bridge,
        websockets.connect(bridge.url, max_size=None) as publisher,
        websockets.connect(bridge.url, max_size=None) as reader,
        websockets.connect(bridge.url, subprotocols=[FOXGLOVE], max_queue=1) as stalled,
    ):
        topic = {"topic": "/bulk", "type": "std_msgs/msg/String"}
        await publisher.send(json.dumps({"op": "advertise", **topic}))
        await reader.send(json.dumps({"op": "subscribe", **topic, "id": "r"}))
        channel = await wait_for_channel(stalled, "/bulk")
        request = {"op": "subscribe", "subscriptions": [{"id": 1, "channelId": channel}]}
        await stalled.send(orjson.dumps(request).decode())
        subscribed = bridge.core.state.topic_subscriptions
        async with asyncio.timeout(10):  # both subscriptions in place
            while len(subscribed.get("/bulk", {})) < 2:
                await asyncio.sleep(0.01)
        count = 300
        received = 0

        async def read_all() -> None:
            nonlocal received
            while received < count:
                message = json.loads(await reader.recv())
                received += message.get("op") == "publish"

        reading = asyncio.create_task(read_all())
        for _ in range(count):
            await publisher.send(json.dumps({"op": "publish", "topic": "/bulk", "msg": payload}))
        await asyncio.wait_for(reading, 30)
        stats = bridge.server.stats()
        foxglove_id = max(stats)
        assert received == count  # the reader lost nothing
        assert stats[foxglove_id]["dropped"].get("/bulk", 0) > 0, stats[foxglove_id]


async def wait_for_channel(ws: Any, topic: str) -> int:
    """The channel id of `topic` once it is advertised."""
    while True:
        channels = (await next_json(ws, "advertise"))["channels"]
        found = [c["id"] for c in channels if c["topic"] == topic]
        if found:
            return int(found[0])


async def test_hostile_frames_get_a_status_and_one_log_line_each(
    caplog: pytest.LogCaptureFixture,
) -> None:
    hostile: list[str | bytes] = [
        "{not json",
        '{"op": "frobnicate"}',
        b"\x09\x00",
        b"\x01\x05\x00\x00\x00cdr",
        '{"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 424242}]}',
    ]
    async with (
        run_bridge(BridgeConfig(port=0)) as bridge,
        websockets.connect(bridge.url, subprotocols=[FOXGLOVE]) as ws,
    ):
        for frame in hostile:
            await ws.send(frame)
            status = await next_json(ws, "status")
            assert status["level"] == 2
        await ws.send('{"op": "subscribeConnectionGraph"}')  # still served
        assert "publishedTopics" in await next_json(ws, "connectionGraphUpdate")
    lines = [r.getMessage() for r in caplog.records if "Foxglove op=" in r.getMessage()]
    assert len(lines) == len(hostile), lines
    assert lines[1].endswith("Foxglove op=?: unknown op: 'frobnicate'")
    assert "op=binary opcode 1: message on unknown client channel 5" in lines[3]
    assert all(line.startswith("[/rosbridge_client_") for line in lines)


async def test_a_foxglove_publisher_is_paced_so_a_reader_loses_nothing() -> None:
    """A burst of 30 MB from a Foxglove client: the bridge stops reading it while the
    subscriber's queue is backed up, as it does for a rosbridge publisher."""
    config = BridgeConfig(port=0, send_buffer_bytes=4 * 1024 * 1024)
    text = "y" * 100_000
    count = 300
    async with (
        run_bridge(config) as bridge,
        websockets.connect(bridge.url, max_size=None) as reader,
        websockets.connect(bridge.url, subprotocols=[FOXGLOVE]) as publisher,
    ):
        topic = {"topic": "/burst", "type": "std_msgs/msg/String"}
        await reader.send(json.dumps({"op": "subscribe", **topic, "id": "r"}))
        channel = {"id": 1, "topic": "/burst", "encoding": "json", "schemaName": topic["type"]}
        await publisher.send(json.dumps({"op": "advertise", "channels": [channel]}))
        await asyncio.sleep(0.2)  # (both ops handled)
        frame = b"\x01\x01\x00\x00\x00" + orjson.dumps({"data": text})

        async def read_all() -> int:
            """Messages received until all came or none came for 5 s (some were lost)."""
            received = 0
            with contextlib.suppress(TimeoutError):
                while received < count:
                    message = json.loads(await asyncio.wait_for(reader.recv(), 5))
                    received += message.get("op") == "publish"
            return received

        reading = asyncio.create_task(read_all())
        for _ in range(count):
            await publisher.send(frame)
        reader_id = min(bridge.server.stats())
        assert await reading == count, bridge.server.stats()[reader_id]
        assert bridge.server.stats()[reader_id]["dropped"] == {}
